#!/usr/bin/python3
"""Checks executed notebooks: every code cell that saves a figure (savefig) shows it inline
(an image/png output), no output names a machine's absolute path, and no cell raised.
Usage: check_outputs.py NOTEBOOK.ipynb...   Exit 1 with one line per defect."""
import json
import re
import sys

ABSOLUTE = re.compile(r"(?<![\w.~])/(?:work|home|tmp|root|builds?|srv|mnt)/")


def text_of(output):
    parts = [output.get("text", "")]
    for kind, value in output.get("data", {}).items():
        if kind.startswith("text/"):
            parts.append(value)
    parts += output.get("traceback", [])
    return "".join("".join(p) if isinstance(p, list) else p for p in parts)


def defects(path):
    with open(path, encoding="utf-8") as f:
        nb = json.load(f)
    found = []
    for i, cell in enumerate(nb.get("cells", [])):
        if cell.get("cell_type") != "code":
            continue
        source = "".join(cell.get("source", ""))
        outputs = cell.get("outputs", [])
        images = sum("image/png" in o.get("data", {}) for o in outputs)
        saves = len(re.findall(r"\bsavefig\(", source))
        if images < saves:
            found.append(f"{path}: cell {i}: {saves} figure(s) saved, {images} shown inline")
        for o in outputs:
            if o.get("output_type") == "error":
                found.append(f"{path}: cell {i}: raised {o.get('ename')}")
            m = ABSOLUTE.search(text_of(o))
            if m:
                found.append(f"{path}: cell {i}: output names an absolute path ({m.group(0)}...)")
    return found


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit("usage: check_outputs.py NOTEBOOK.ipynb...")
    problems = [d for p in sys.argv[1:] for d in defects(p)]
    print("\n".join(problems) if problems else f"{len(sys.argv) - 1} notebook(s): figures inline, no absolute paths, no errors")
    sys.exit(1 if problems else 0)
