"""The blocks of the paper's Fig 6 controller and its plant; `hybridsim blocks` lists them first."""
from hybridsim.engine.registry import list_first

list_first("paper")
