"""The file formats: reading, checking and building diagram and sweep files.

One module per job:

* :mod:`.yamlio` reads YAML (files and ``--set`` values) with file:line, within the limits;
* :mod:`.extends` merges a file over the file it ``extends``;
* :mod:`.kinds` and :mod:`.tables`: one declarative table per section (key, kind, default, doc),
  which checks the section and gives its JSON Schema, defaults and docs;
* :mod:`.paths`: :class:`ParamPath`, the one parsed type of a parameter path;
* :mod:`.overrides`: ``--set``, ``variants``, run-time parameters;
* :mod:`.expand`: subsystems flattened, blocks constructed, the block budget;
* :mod:`.settings`: the settings sections and the budgets of a run;
* :mod:`.diagram_file`: :class:`DiagramFile`, which ties them together;
* :mod:`.identity`: what a run reads (its identity) and the lock of an output folder.
"""
from hybridsim.format.diagram_file import DiagramFile
from hybridsim.format.paths import ParamPath
from hybridsim.format.yamlio import NumberLoader, parse_file, parse_value

