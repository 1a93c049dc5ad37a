"""The MCL language server (``mcl lsp``): diagnostics from the parser, the checker and the
verifier, hover, definition, rename, completion, symbols, code actions and inlay hints
(docs/EDITORS.md). ``server`` registers the features; each other module is one of them."""
