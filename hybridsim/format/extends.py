"""``extends``: a diagram file read over the file it starts from, key by key."""
from pathlib import Path

from hybridsim import limits
from hybridsim.engine.registry import closest
from hybridsim.errors import LoaderError
from hybridsim.format.yamlio import _List, not_a_file, parse_file

#: sections merged key by key when a file extends another
MERGED_BY_KEY = ("params", "simulation", "signals", "metrics", "plot", "variants", "analysis")
#: the sections of settings, where a key given as null undoes the base's value
UNDONE_BY_NULL = ("simulation", "signals", "metrics", "plot", "analysis")

def read_merged(path, chain=(), budget=None, files=None):
    """Parse ``path`` and merge it over the file it ``extends`` (if any).

    Merging: ``params``, ``simulation``, ``signals``, ``metrics``, ``plot``,
    ``variants`` and ``analysis`` are updated key by key; a block given again
    with a ``type`` replaces the base block, without one it updates the base
    block's parameters, and ``name: null`` removes it with its wires;
    ``wires`` and ``log`` are appended; other keys replace.
    """
    budget = limits.get("MAX_FILE_BYTES") if budget is None else budget
    data, used = parse_file(path, budget)
    if files is not None:
        files.append(Path(path).resolve())
    base_name = data.get("extends")
    if base_name is None:
        return data
    line = data.lines["extends"]
    if not isinstance(base_name, str) or not base_name:
        raise LoaderError(f"'extends' must be a file name, got {base_name!r}", path, line)
    if Path(base_name).suffix.lower() not in limits.YAML_SUFFIXES:
        raise LoaderError(f"'extends': {base_name!r} is not a YAML file (it must end in "
                          f"{' or '.join(limits.YAML_SUFFIXES)})", path, line)
    base_path = (path.parent / base_name).resolve()
    if base_path in chain or base_path == path.resolve():
        raise LoaderError(f"'extends' forms a cycle through {base_name!r}", path, line)
    why = not_a_file(base_path)
    if why == "no such file":
        raise LoaderError(f"'extends': no such file {base_name!r}", path, line)
    if why:
        raise LoaderError(f"'extends' {base_name!r}: {why}", path, line)
    if len(chain) >= limits.get("MAX_EXTENDS"):
        raise LoaderError(f"'extends' chains more than {limits.get('MAX_EXTENDS')} files" + limits.raise_hint('MAX_EXTENDS'), path, line)
    base = read_merged(base_path, chain + (path.resolve(),), budget - used, files)
    merged = base
    for key, val in data.items():
        if key == "extends":
            continue
        cur = merged.get(key)
        if val is None and cur is not None and (key in MERGED_BY_KEY or key in ("wires", "log")):
            raise LoaderError(f"section {key!r} is empty (null), which would drop that section of {base_name}: "
                              f"leave it out to keep it, or write {key}: {'[]' if key in ('wires', 'log') else '{}'} "
                              "to add nothing", path, data.lines[key])
        if key == "blocks" and isinstance(cur, dict) and isinstance(val, dict):
            for bname, spec in val.items():
                if spec is None and bname in cur:  # 'name: null' removes a base block and its wires
                    del cur[bname]
                    _drop_wires(merged, bname)
                    continue
                if spec is None:
                    raise LoaderError(f"block {bname!r}: null removes a block of {base_name!r}, which has none of "
                                      f"that name{closest(bname, cur)}", path, val.lines.get(bname))
                if isinstance(spec, dict) and "type" not in spec and isinstance(cur.get(bname), dict):
                    cur[bname].update(spec)
                    cur[bname].lines.update(spec.lines)
                    cur[bname].locs.update(spec.locs)
                    _merge_key_lines(cur[bname], spec)
                else:
                    cur[bname] = spec
                    cur.lines[bname] = val.lines[bname]
                    cur.locs[bname] = val.locs[bname]
                    _merge_key_lines(cur, val, bname)
        elif key in MERGED_BY_KEY and isinstance(cur, dict) and isinstance(val, dict):
            undone = [k for k, v in val.items() if v is None and k in cur and key in UNDONE_BY_NULL]
            cur.update(val)
            for k in undone:  # 'key: null' undoes the base's setting: its default again
                del cur[k]
            cur.lines.update(val.lines)
            cur.locs.update(val.locs)
            _merge_key_lines(cur, val)
        elif key in ("wires", "log") and isinstance(cur, list) and isinstance(val, list):
            cur.extend(val)
            cur.lines.extend(val.lines)
            cur.locs.extend(val.locs)
        else:
            merged[key] = val
        merged.lines[key] = data.lines[key]
        merged.locs[key] = data.locs[key]
        _merge_key_lines(merged, data, key)
    return merged


def _merge_key_lines(into, given, key=None):
    """The lines where ``given``'s keys (or its ``key`` alone) are written, over those of ``into``."""
    if into.key_lines is None:
        into.key_lines = {}
    for k in (given.key_lines or {}) if key is None else [key]:
        if k in (given.key_lines or {}):
            into.key_lines[k] = given.key_lines[k]


def _drop_wires(data, bname):
    """Remove the wires of ``data`` that touch block ``bname``."""
    wires = data.get("wires")
    if not isinstance(wires, list):
        return
    keep = [k for k, w in enumerate(wires)
            if not any(str(e).strip().split(".")[0] == bname
                       for e in (w.split("->") if isinstance(w, str) else w))]
    new = _List(wires[k] for k in keep)
    new.line, new.lines, new.locs = wires.line, [wires.lines[k] for k in keep], [wires.locs[k] for k in keep]
    data["wires"] = new
    log = data.get("log")
    if isinstance(log, list):
        keep = [k for k, r in enumerate(log) if str(r).split(".")[0] != bname]
        new = _List(log[k] for k in keep)
        new.line, new.lines, new.locs = log.line, [log.lines[k] for k in keep], [log.locs[k] for k in keep]
        data["log"] = new
