"""One Petri-net template per MCL construct (docs/DESIGN.md §5), each in a module of its own."""
