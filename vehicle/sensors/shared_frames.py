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


class SharedImage:
    """One image of a known ``shape`` in a block of shared memory, behind a byte set once it
    is there: the wall's texture, which the camera's worker makes at its start and the mosaic
    measures against at the end of the run (0.8 s of CPU not spent again). The owner (the main
    process) makes the block and removes it (:meth:`close`); the worker opens it by
    :attr:`name` and puts the image in (:meth:`put`)."""

    def __init__(self, shape: tuple[int, ...], name: str | None = None) -> None:
        self.shape, self.owner = shape, name is None
        size = 1 + int(np.prod(shape))
        self.block: shared_memory.SharedMemory | None = (
            shared_memory.SharedMemory(create=True, size=size) if name is None
            else shared_memory.SharedMemory(name=name))
        self.name = self.block.name

    def put(self, img: Image) -> bool:
        """(Worker) Copy the image in; False if it has another shape."""
        if self.block is None or img.shape != self.shape:
            return False
        buf = _buffer(self.block)
        np.ndarray(self.shape, dtype=np.uint8, buffer=buf, offset=1)[...] = img
        buf[0] = 1
        return True

    def get(self) -> Image | None:
        """(Owner) A copy of the image, None if the worker has not put it there (yet)."""
        if self.block is None or _buffer(self.block)[0] != 1:
            return None
        return np.ndarray(self.shape, dtype=np.uint8, buffer=_buffer(self.block),
                          offset=1).copy()

    def close(self) -> None:
        """Let go of the block; the owner removes it. Safe to call twice."""
        block, self.block = self.block, None
        if block is not None:
            block.close()
            if self.owner:
                block.unlink()


def _buffer(block: shared_memory.SharedMemory) -> memoryview:
    """The block's memory (open until closed)."""
    buf = block.buf
    assert buf is not None, "a closed block"
    return buf
