"""hybridsim's version (pyproject.toml's), in a module of its own: what the format layer and the
FMU export stamp on their outputs without importing the whole package."""
__version__ = "0.1.0"
