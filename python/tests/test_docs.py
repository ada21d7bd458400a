"""The examples of README.md and docs/FLEET.md, run as written.

A ```console block is a sequence of `$ command` lines, each followed by the output it prints
(standard output and standard error merged, as a terminal shows them). The console blocks of a
document run in order in ONE fresh directory per document, laid out like a clone: the commands
are written from the repository's root (`python python/examples/quickstart.py`,
`../shared/data/plant`) and later blocks use the files of earlier ones (`simulate -o loop.csv`,
then `quantify loop.csv`). So the directory is `TMP/clone` with the repository's top-level
entries linked into it (its `target/` apart) and `TMP/shared` linked to the repository's
`../shared` when that exists. `stiction` is the CLI under test ($STICTION_BIN or the workspace's
build, conftest.py), `python` this interpreter, both first on PATH; each command runs through
`bash -c`, so pipes work. Commands starting with `cargo` run in the repository itself (they
need its workspace, and reuse its `target/`).

Checked: the exit status (non-zero exactly when the documented output has an `error:` line)
and the output, line by line after two maskings (wall times: `22 ms`, `(…, 33 ms)` and the
`0.0s` closing a line of `compare`'s table) and trailing blanks; a documented line
`...something...` stands for any number of lines. Everything else must match exactly, so the
printed numbers stay true.

Skipped, with the reason: a command naming `../shared` when the shared plant data are absent,
a `cargo` command when cargo is not installed. A ```python block is compiled; it is run unless
the line before it is `<!-- not run: REASON -->`, or it shows the file that the next console
block runs (`python FILE`), which must then be the file's exact content.
"""

from __future__ import annotations

import difflib
import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ["README.md", "docs/FLEET.md"]
SHARED = ROOT.parent / "shared"
NOT_RUN = re.compile(r"^<!--\s*not run:\s*(.+?)\s*-->$")
WILDCARD = re.compile(r"^\.\.\.(.*\.\.\.)?$")
# Wall times, the only figures that change from run to run: `22 ms`, `(30 figure files,
# 6607 kB, 33 ms)`, and the `time` column (`0.0s`) that closes a line of `compare`'s table.
MASKS = [
    (re.compile(r"\b\d+(\.\d+)? ?ms\b"), "<ms>"),
    (re.compile(r"\s+\d+\.\ds$"), " <s>"),  # right-aligned: its width varies too
]


@dataclass
class Block:
    doc: str
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    marker: str | None = None  # the reason of a `<!-- not run: ... -->` line before it

    @property
    def id(self) -> str:
        return f"{self.doc}:{self.line}"


@dataclass
class Command:
    line: int
    cmd: str
    expected: list[str] = field(default_factory=list)


def blocks(doc: str) -> list[Block]:
    """The fenced blocks of a document, with their language and line."""
    lines = (ROOT / doc).read_text().splitlines()
    out, i = [], 0
    while i < len(lines):
        m = re.match(r"^```(\S*)", lines[i])
        if not m:
            i += 1
            continue
        start = i
        i += 1
        body = []
        while i < len(lines) and not lines[i].startswith("```"):
            body.append(lines[i])
            i += 1
        prev = next((lines[j].strip() for j in range(start - 1, -1, -1) if lines[j].strip()), "")
        marker = NOT_RUN.match(prev)
        out.append(Block(doc, start + 1, m.group(1), "\n".join(body) + "\n",
                         marker.group(1) if marker else None))
        i += 1
    return out


def commands(block: Block) -> list[Command]:
    """A console block's `$ command` lines with their documented output."""
    out = []
    for k, line in enumerate(block.text.splitlines()):
        if line.startswith("$ "):
            assert not line.endswith("\\"), f"{block.id}: continued command lines are not supported"
            out.append(Command(block.line + 1 + k, line[2:]))
        else:
            assert out, f"{block.id}: output before the first `$ ` command: {line!r}"
            out[-1].expected.append(line)
    return out


def normalise(lines: list[str]) -> list[str]:
    out = []
    for line in lines:
        line = line.rstrip()
        for pattern, mask in MASKS:
            line = pattern.sub(mask, line)
        out.append(line)
    while out and not out[-1]:
        out.pop()
    return out


def matches(expected: list[str], actual: list[str]) -> bool:
    """Line-by-line equality, a wildcard line standing for any number of lines (0 or more)."""
    memo: dict[tuple[int, int], bool] = {}

    def go(i: int, j: int) -> bool:
        if (i, j) not in memo:
            if i == len(expected):
                r = j == len(actual)
            elif WILDCARD.match(expected[i]):
                r = any(go(i + 1, k) for k in range(j, len(actual) + 1))
            else:
                r = j < len(actual) and expected[i] == actual[j] and go(i + 1, j + 1)
            memo[(i, j)] = r
        return memo[(i, j)]

    return go(0, 0)


def skip_reason(cmd: str) -> str | None:
    if "../shared" in cmd and not SHARED.is_dir():
        return f"{SHARED} is absent (the shared plant data beside the repository)"
    if cmd.startswith("cargo ") and shutil.which("cargo") is None:
        return "cargo is not installed"
    return None


class Clone:
    """One document's directory: a clone's layout, `stiction` and `python` first on PATH."""

    def __init__(self, tmp: Path, stiction: str):
        self.dir = tmp / "clone"
        self.dir.mkdir()
        for entry in ROOT.iterdir():
            if entry.name != "target" and not entry.name.startswith("."):
                (self.dir / entry.name).symlink_to(entry)
        if SHARED.is_dir():
            (tmp / "shared").symlink_to(SHARED)
        bin_dir = tmp / "bin"
        bin_dir.mkdir()
        (bin_dir / "stiction").symlink_to(Path(stiction).resolve())
        # A wrapper, not a link: a link to a virtual environment's interpreter outside the
        # environment's folder would not find the environment's packages.
        py = bin_dir / "python"
        py.write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
        py.chmod(0o755)
        path = f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"
        # Python's output unbuffered, as at a terminal: merged with stderr in the order written.
        self.env = dict(os.environ, PATH=path, PYTHONUNBUFFERED="1")

    def run(self, cmd: str) -> subprocess.CompletedProcess:
        cwd = ROOT if cmd.startswith("cargo ") else self.dir
        return subprocess.run(["bash", "-c", cmd], cwd=cwd, env=self.env, stdin=subprocess.DEVNULL,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              timeout=1800)


class DocRun:
    """Runs a document's console blocks in order, each once, as far as a test needs."""

    def __init__(self, doc: str, tmp: Path, stiction: str):
        self.clone = Clone(tmp, stiction)
        self.blocks = [b for b in blocks(doc) if b.lang == "console"]
        self.results: dict[int, list] = {}

    def result(self, block: Block) -> list:
        for b in self.blocks:
            if b.line not in self.results:
                self.results[b.line] = self._run(b)
            if b.line == block.line:
                return self.results[b.line]
        raise KeyError(block.id)

    def _run(self, block: Block) -> list:
        """Per command: (command, None, skip reason) or (command, completed process, None)."""
        out = []
        for c in commands(block):
            reason = skip_reason(c.cmd)
            if reason:
                out.append((c, None, reason))
                break  # the commands after it may need what it would have written
            out.append((c, self.clone.run(c.cmd), None))
        return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory, stiction_bin):
    made: dict[str, DocRun] = {}

    def get(doc: str) -> DocRun:
        if doc not in made:
            made[doc] = DocRun(doc, tmp_path_factory.mktemp(Path(doc).stem), stiction_bin)
        return made[doc]

    return get


CONSOLE = [b for d in DOCS for b in blocks(d) if b.lang == "console"]
PYTHON = [b for d in DOCS for b in blocks(d) if b.lang == "python"]


def check_command(c: Command, r: subprocess.CompletedProcess, where: str) -> None:
    expected, actual = normalise(c.expected), normalise(r.stdout.splitlines())
    diff = "\n".join(difflib.unified_diff(expected, actual, "documented", "printed", lineterm=""))
    assert matches(expected, actual), f"{where}: `$ {c.cmd}` prints otherwise:\n{diff}"
    fails = any(line.startswith("error:") for line in c.expected)
    if fails:
        assert r.returncode != 0, f"{where}: `$ {c.cmd}` documents an error but exits with 0"
    else:
        assert r.returncode == 0, f"{where}: `$ {c.cmd}` exits with {r.returncode}:\n{r.stdout}"


@pytest.mark.parametrize("block", CONSOLE, ids=lambda b: b.id)
def test_console_block_runs_as_written(block, runs):
    for c, r, reason in runs(block.doc).result(block):
        if reason:
            pytest.skip(f"{block.doc}:{c.line}: `$ {c.cmd}` not run: {reason}")
        check_command(c, r, f"{block.doc}:{c.line}")


def shown_file(block: Block) -> Path | None:
    """The file a python block shows: the next block is a console block running `python FILE`."""
    doc_blocks = blocks(block.doc)
    k = next(i for i, b in enumerate(doc_blocks) if b.line == block.line)
    if k + 1 < len(doc_blocks) and doc_blocks[k + 1].lang == "console":
        first = commands(doc_blocks[k + 1])[0].cmd.split()
        if first[0] == "python" and len(first) == 2:
            return ROOT / first[1]
    return None


@pytest.mark.parametrize("block", PYTHON, ids=lambda b: b.id)
def test_python_block_compiles(block):
    compile(block.text, block.id, "exec")


@pytest.mark.parametrize("block", PYTHON, ids=lambda b: b.id)
def test_python_block_runs(block, runs, tmp_path):
    if block.marker:
        pytest.skip(f"{block.id} not run: {block.marker}")
    shown = shown_file(block)
    if shown is not None:
        # the next console block runs the file (test_console_block_runs_as_written)
        assert shown.read_text() == block.text, f"{block.id} is not the content of {shown}"
        return
    reason = skip_reason(block.text)
    if reason:
        pytest.skip(f"{block.id} not run: {reason}")
    clone = runs(block.doc).clone
    script = clone.dir / f"block_{block.line}.py"
    script.write_text(block.text)
    r = clone.run(f"python {script.name}")
    assert r.returncode == 0, f"{block.id} as a script exits with {r.returncode}:\n{r.stdout}"


def test_the_checker_can_fail():
    """The matcher rejects a changed number, a missing line and an unmasked figure."""
    doc = ["a 1.00 %", "...", "z 22 ms", "done 0.1s"]
    assert matches(normalise(doc), normalise(["a 1.00 %", "b", "c", "z 9 ms", "done 3.4s"]))
    assert matches(normalise(doc), normalise(["a 1.00 %", "z 9 ms", "done 3.4s"]))
    assert not matches(normalise(doc), normalise(["a 1.01 %", "z 9 ms", "done 3.4s"]))
    assert not matches(normalise(doc), normalise(["a 1.00 %", "z 9 ms"]))
    assert not matches(normalise(["ti 1.00 s (explains)"]), normalise(["ti 2.00 s (explains)"]))
    assert not matches(normalise(["6607 kB"]), normalise(["6608 kB"]))
