"""The photomosaic of the dam wall (paper 002 §6), built from a run's images.

The steps, one module each: :mod:`mosaic.images` (a run's images and their navigation data),
:mod:`mosaic.projection` (the pinhole camera of §6.1 against the wall plane),
:mod:`mosaic.illumination` (flat-field correction; damaged images set aside),
:mod:`mosaic.registration` (features, robust matching of consecutive and overlapping
non-consecutive pairs, §6.2, §6.4), :mod:`mosaic.alignment` (global alignment by sparse least
squares over every registered pair with the navigator as a prior, §6.5), :mod:`mosaic.blending`
(the mosaic in the wall frame and its coverage map, §6.7), :mod:`mosaic.accuracy` (the
figures against the simulation's ground truth), :mod:`mosaic.stages` (the pipeline's stages, one function each), :mod:`mosaic.build` (the whole
pipeline and its figures),
:mod:`app.mosaic` (``mcl mosaic``) and :mod:`mosaic.hook` (what ``mcl run`` calls).
See docs/MOSAIC.md.
"""
