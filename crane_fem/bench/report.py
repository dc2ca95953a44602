"""Where a suite's results go: its block of ``benchmarks/RESULTS.md``, replaced in place on
each run and headed by the command that made it."""

from __future__ import annotations

import re
from pathlib import Path

__all__ = ["RESULTS", "update_results"]

#: The research log of the benchmarks (in the checkout).
RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "RESULTS.md"


def update_results(path: Path, key: str, title: str, command: str, body: str) -> None:
    """Put ``body`` under ``## title`` in the block marked ``key`` of ``path`` (appended at
    the end the first time; later runs replace the block and leave the rest of the file)."""
    begin, end = f"<!-- bench:{key}:begin -->", f"<!-- bench:{key}:end -->"
    block = f"{begin}\n## {title}\n\nCommand: `{command}`\n\n{body.rstrip()}\n{end}"
    text = path.read_text(encoding="utf-8") if path.is_file() else "# Benchmark results\n"
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if pattern.search(text):
        text = pattern.sub(lambda _: block, text)
    else:
        text = text.rstrip() + "\n\n" + block + "\n"
    path.write_text(text, encoding="utf-8")
