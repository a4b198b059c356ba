"""The marked blocks of BENCHMARKS.md that the bench scripts rewrite (shared by
`tools/bench-trade.py`, `tools/bench-leaf-size.py` and `tools/bench-breakdown.py`)."""

import pathlib
import sys


def replace_block(path, name, text):
    """Replaces what stands between `<!-- NAME:begin -->` and `<!-- NAME:end -->` in the
    file at `path` with `text`; exits with a message when the markers are missing."""
    path = pathlib.Path(path)
    doc = path.read_text()
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    if begin not in doc or end not in doc:
        sys.exit(f"{path}: no {begin} … {end} block to replace")
    head, rest = doc.split(begin, 1)
    _, tail = rest.split(end, 1)
    path.write_text(head + begin + "\n" + text + "\n" + end + tail)
