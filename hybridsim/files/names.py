"""File names from diagram and run names: plain, never a path, never two alike."""
import hashlib
import re


def safe_name(name, default="diagram"):
    """``name`` as a plain file name: letters, digits, ``-_.+=,``; no path, no leading dot.

    >>> safe_name("../../x")
    'x'
    """
    text = re.sub(r"[^A-Za-z0-9_.+=,-]+", "-", str(name))
    text = text.strip(".-")
    return text[:120] or default


def unique_names(labels, stem, default="run"):
    """File stems for ``labels`` (run labels) that cannot collide: ``stem_slug``, with a short hash of
    the label where two slugs (or a slug and ``stem`` itself) would be the same name (case-folded)."""
    slugs = [(stem + "_" + _slug(lab, default)) if lab else stem for lab in labels]
    seen = {}
    for s in slugs:
        seen[s.lower()] = seen.get(s.lower(), 0) + 1
    out = []
    for lab, s in zip(labels, slugs):
        if seen[s.lower()] > 1:
            s = f"{s}_{hashlib.sha1(str(lab).encode()).hexdigest()[:6]}"
        out.append(s)
    return out


def _slug(label, default="run"):
    return safe_name("".join(c if c.isalnum() or c in "-." else "-" for c in str(label).replace("=", "")), default)
