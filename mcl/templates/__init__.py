"""One Petri-net template per MCL construct (MCL.md §5), each in a module of its own."""
