"""A run's camera images in shared memory, beside their PNG files.

The camera's worker process (vehicle/sensors/image_worker.py) renders each image and writes it
as a PNG; the mosaic that ``mcl run`` builds at the end would read every PNG back and decode it
(1.4 ms an image: 1.8 s of CPU for the dam mission's 1,329). The worker also copies each
image's pixels into shared memory (a few microseconds), where the main process reads them as
they are — the same pixels, PNG being lossless.

The memory is in blocks of :data:`BLOCK` images, made by the main process as the images are
taken and removed by it when the mosaic is built (:meth:`SharedFrames.close`); should the main
process be killed, the resource tracker of :mod:`multiprocessing` removes them.
"""

from __future__ import annotations

from multiprocessing import shared_memory

import numpy as np

from vehicle.sensors.wall_texture import Image

BLOCK = 128  # images a block: 29 MB of 320 x 240 colour images
SHAPE = (240, 320, 3)  # the wall camera's (vehicle/sensors/camera.py)


class SharedFrames:
    """Images ``0, 1, ...`` of one ``shape`` in blocks of shared memory. The owner (the main
    process) makes the blocks (:meth:`block_for`), the worker opens them by name
    (:meth:`put`); :meth:`get` reads an image in place."""

    def __init__(self, shape: tuple[int, int, int] = SHAPE, owner: bool = True) -> None:
        self.shape, self.owner = shape, owner
        self.blocks: dict[int, shared_memory.SharedMemory] = {}
        self.size = int(np.prod(shape))

    def block_for(self, index: int) -> str | None:
        """(Owner) The name of a block made for image ``index`` if it is the first of a new
        block, else None (the worker already has it)."""
        b = index // BLOCK
        if b in self.blocks:
            return None
        self.blocks[b] = shared_memory.SharedMemory(create=True, size=BLOCK * (1 + self.size))
        return self.blocks[b].name

    def open(self, index: int, name: str) -> None:
        """(Worker) Open the block of image ``index`` by the name the owner gave."""
        self.blocks[index // BLOCK] = shared_memory.SharedMemory(name=name)

    def _view(self, index: int) -> Image | None:
        """Image ``index`` in its block: a byte a slot first (1 once the image is there), then
        the images."""
        block = self.blocks.get(index // BLOCK)
        if block is None:
            return None
        at = BLOCK + (index % BLOCK) * self.size
        return np.ndarray(self.shape, dtype=np.uint8, buffer=block.buf, offset=at)

    def put(self, index: int, img: Image) -> bool:
        """(Worker) Copy image ``index`` into its block; False if it has no block or another
        shape (then only its PNG has it)."""
        view = self._view(index)
        if view is None or img.shape != self.shape:
            return False
        view[...] = img
        _buffer(self.blocks[index // BLOCK])[index % BLOCK] = 1
        return True

    def get(self, index: int) -> Image | None:
        """(Owner) Image ``index`` in place (valid until :meth:`close`), None if the worker
        did not put it there."""
        block = self.blocks.get(index // BLOCK)
        if block is None or _buffer(block)[index % BLOCK] != 1:
            return None
        view = self._view(index)
        if view is not None:
            view.flags.writeable = False
        return view

    def close(self) -> None:
        """Let go of the blocks; the owner removes them."""
        blocks, self.blocks = self.blocks, {}
        for block in blocks.values():
            try:
                block.close()
            except BufferError:  # a view still held: the memory goes when it is dropped
                pass
            if self.owner:
                block.unlink()


def _buffer(block: shared_memory.SharedMemory) -> memoryview:
    """The block's memory (open until closed)."""
    buf = block.buf
    assert buf is not None, "a closed block"
    return buf
