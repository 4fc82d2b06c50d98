"""Built-in junction maps (YAML data files, format in docs/embedded.md)."""
