#!/usr/bin/env python3
"""The documentation's checks: README.md, CHANGELOG.md and docs/*.md, read as a user reads them.

- Every fenced `sh` block runs as written, from the repository's root, with bash (-e, -o
  pipefail), each in turn; a block that fails fails the check, with its output. A block that
  names ../shared/meshes is skipped, with the reason, when those meshes are absent. A block
  preceded by `<!-- doc-test: expensive -->` (a benchmark of minutes) runs only with --all.
- A block preceded by `<!-- doc-test: same as FILE -->` must equal FILE, byte for byte.
- Every table has as many cells in each row as in its header and its delimiter row.
- Every relative link and image names a file that exists, and a #heading that exists in it.

`text` blocks (synopses with [options]) and blocks in other languages are not run.

    tests/docs/doc_test.py [--build-dir DIR] [--all] [--only FILE] [--list]
"""
import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FENCE = re.compile(r"^```(\w*)\s*$")
MARKER = re.compile(r"^<!--\s*doc-test:\s*(.*?)\s*-->\s*$")
LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)\)")


class Block:
    def __init__(self, path, line, language, text, marker):
        self.path, self.line, self.language, self.text, self.marker = path, line, language, text, marker

    def where(self):
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def documents():
    return [ROOT / "README.md", ROOT / "CHANGELOG.md"] + sorted((ROOT / "docs").glob("*.md"))


def blocks_of(path):
    """The fenced blocks of a Markdown file, each with the doc-test marker right before it."""
    lines = path.read_text(encoding="utf-8").split("\n")
    blocks, i, marker = [], 0, None
    while i < len(lines):
        opening = FENCE.match(lines[i])
        found = MARKER.match(lines[i])
        if found:
            marker = found.group(1)
        elif opening:
            start = i
            i += 1
            body = []
            while i < len(lines) and not lines[i].startswith("```"):
                body.append(lines[i])
                i += 1
            blocks.append(Block(path, start + 1, opening.group(1), "\n".join(body) + "\n", marker))
            marker = None
        elif lines[i].strip():
            marker = None
        i += 1
    return blocks


def outside_blocks(path):
    """(line number, text) of the lines outside fenced blocks."""
    inside = False
    for number, line in enumerate(path.read_text(encoding="utf-8").split("\n"), 1):
        if line.startswith("```"):
            inside = not inside
            continue
        if not inside:
            yield number, line


def cells(row):
    """The cells of a table row: split at | outside `code` and not escaped."""
    count, in_code, previous = 0, False, ""
    for character in row.strip().strip("|"):
        if character == "`":
            in_code = not in_code
        elif character == "|" and not in_code and previous != "\\":
            count += 1
        previous = character
    return count + 1


def check_tables(path):
    problems = []
    table = []
    for number, line in list(outside_blocks(path)) + [(0, "")]:
        if line.lstrip().startswith("|"):
            table.append((number, line))
            continue
        if table:
            header = cells(table[0][1])
            if len(table) < 2 or not re.match(r"^\s*\|(\s*:?-+:?\s*\|)+\s*$", table[1][1]):
                problems.append(f"{path.relative_to(ROOT)}:{table[0][0]}: a table without a delimiter row under its header")
            for row_number, row in table[1:]:
                if cells(row) != header:
                    problems.append(f"{path.relative_to(ROOT)}:{row_number}: {cells(row)} cells where the header has {header}")
            table = []
    return problems


def slug(heading):
    """GitHub's anchor for a heading."""
    text = re.sub(r"[`*_]", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors_of(path):
    found = set()
    for _, line in outside_blocks(path):
        heading = re.match(r"^#{1,6}\s+(.*?)\s*(\{#[\w-]+\})?\s*$", line)
        if heading:
            found.add(slug(heading.group(1)))
    return found


def check_links(path):
    problems = []
    for number, line in outside_blocks(path):
        for target in LINK.findall(line):
            if re.match(r"^[a-z]+:", target):
                continue  # http:, https:, mailto:
            file_part, _, anchor = target.partition("#")
            destination = (path.parent / file_part).resolve() if file_part else path
            if not destination.exists():
                problems.append(f"{path.relative_to(ROOT)}:{number}: the link {target} names a file that does not exist")
                continue
            if anchor and destination.suffix == ".md" and anchor not in anchors_of(destination):
                problems.append(f"{path.relative_to(ROOT)}:{number}: the link {target} names a heading that does not exist")
    return problems


def check_same_as(block):
    reference = ROOT / block.marker[len("same as "):].strip()
    if not reference.exists():
        return f"{block.where()}: the block should equal {reference.relative_to(ROOT)}, which does not exist"
    if reference.read_text(encoding="utf-8").rstrip("\n") != block.text.rstrip("\n"):
        return f"{block.where()}: the block differs from {reference.relative_to(ROOT)}"
    return None


def run_block(block, build_dir, shared):
    """None when the block ran (or was skipped, said on stdout), else the failure."""
    text = block.text
    if "../shared/meshes" in text and not shared.is_dir():
        print(f"doc-test: skipped {block.where()}: it uses ../shared/meshes, absent here")
        return None
    if build_dir != ROOT / "build":
        text = re.sub(r"(?<![\w/.-])build/", str(build_dir) + "/", text)
    (ROOT / "out").mkdir(exist_ok=True)
    start = time.monotonic()
    result = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", text], cwd=ROOT, capture_output=True, text=True,
                            timeout=600, env=dict(os.environ, HDEFORM_NO_GUI="1"))
    seconds = time.monotonic() - start
    if result.returncode != 0:
        output = (result.stdout + result.stderr).strip().split("\n")
        return f"{block.where()}: exit status {result.returncode} from\n{block.text}" + "\n".join(output[-20:])
    print(f"doc-test: ran {block.where()} ({seconds:.1f} s)")
    return None


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build-dir", type=Path, default=ROOT / "build")
    parser.add_argument("--all", action="store_true", help="run the expensive blocks too")
    parser.add_argument("--only", help="one document (a path relative to the repository)")
    parser.add_argument("--list", action="store_true", help="list the blocks that would run")
    arguments = parser.parse_args()
    build_dir = arguments.build_dir.resolve()
    shared = ROOT.parent / "shared" / "meshes"
    paths = [ROOT / arguments.only] if arguments.only else documents()

    problems = []
    for path in paths:
        problems += check_tables(path)
        problems += check_links(path)
        for block in blocks_of(path):
            marker = block.marker or ""
            if marker.startswith("same as "):
                problem = check_same_as(block)
                if problem:
                    problems.append(problem)
                continue
            if block.language != "sh":
                continue
            if marker == "expensive" and not arguments.all:
                print(f"doc-test: skipped {block.where()}: expensive (run with --all)")
                continue
            if marker and marker != "expensive":
                problems.append(f"{block.where()}: unknown doc-test marker '{marker}'")
                continue
            if arguments.list:
                print(f"doc-test: would run {block.where()}")
                continue
            try:
                problem = run_block(block, build_dir, shared)
            except subprocess.TimeoutExpired:
                problem = f"{block.where()}: still running after 600 s"
            if problem:
                problems.append(problem)
    for problem in problems:
        print(f"doc-test: {problem}", file=sys.stderr)
    if problems:
        print(f"doc-test: {len(problems)} problems", file=sys.stderr)
        return 1
    print(f"doc-test: {len(paths)} documents, every table, link and command checked")
    return 0


if __name__ == "__main__":
    sys.exit(main())
