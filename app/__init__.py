"""The application layer: the commands users run (``mclc``, ``mcl run | replay | check |
vehicle | monitor | mosaic``), one module per command, above every library package."""
