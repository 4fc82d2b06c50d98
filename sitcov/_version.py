"""The package version, on its own so that any layer can stamp it without the package face.

``sitcov/__init__.py`` imports every layer; a module below it that needs the version (the
external-stack protocol's handshake, say) takes it from here. Keep it equal to
``pyproject.toml``'s ``version`` (tests/test_public_api.py checks).
"""

__version__ = "0.1.0"
