"""Helpers shared by the benchmark scripts (scripts/bench_*.py): where their tables go and how a script
replaces its own section of docs/benchmarks.md while keeping the others."""

import os

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCHMARKS = os.path.join(ROOT, "docs", "benchmarks.md")


def replace_section(heading, lines, path=BENCHMARKS):
    """Replaces the section under `heading` (a markdown heading line, up to the next heading of its
    level or above) in `path` with `lines`, in place; appends it when there is none."""
    text = open(path).read().rstrip("\n").split("\n") if os.path.exists(path) else ["# Benchmarks"]
    level = len(heading.split(" ")[0])
    if heading in text:
        start = text.index(heading)
        end = next((i for i in range(start + 1, len(text))
                    if text[i].startswith("#") and len(text[i].split(" ")[0]) <= level), len(text))
        text[start:end] = list(lines) + ([""] if end < len(text) else [])
    else:
        text += [""] + list(lines)
    with open(path, "w") as f:
        f.write("\n".join(text).rstrip("\n") + "\n")
