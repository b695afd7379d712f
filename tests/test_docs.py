"""Every fenced code block of the docs (``docs/**/*.md``) and of ``README.md`` runs here, or is
accounted for, so the pages cannot rot.

The rules, by the fence's language:

- ``python``: run in order, all python blocks of one page in one namespace, in a fresh folder that
  is the current one (``random`` and numpy's global generator seeded with 0 first). A block whose
  first line is ``# NAME.py ...`` is a file the user saves: it is written to ``NAME.py`` in that
  folder, not run itself; a later ``bash`` block of the page runs or imports it (checked).
- ``bash``: the whole block runs as one ``bash -euo pipefail`` script in the page's folder, with
  ``.venv/bin/`` rewritten to the bin folder of the Python running the tests (also first on
  ``PATH``) and repository paths that exist (``lcgym/...``, ``results/...``, ``studies/...``, ``scripts/...``,
  ``benchmarks/...``) made absolute; its
  exit status must be 0. Exceptions: the set-up and install commands (``python3 -m venv``,
  ``pip install``) are not run (they would rebuild the venv): each of their ``&&`` parts must be a
  command of ``.ci/run``, which CI runs (CI's ``-q`` and ``--site-dir DIR`` aside), except the main
  job's, which must be CI's test command with ``-e .`` for ``-e ".[test]"`` and
  ``lcgym bench --quick`` for pytest.
- ``text``: output or a synopsis, not code. The ``text`` blocks that follow a ``bash`` block,
  before the next ``python`` or ``bash`` block or heading, are the output it shows (stdout and
  stderr together): each of their lines (blank lines and ``...`` left out) must be a line of what
  the block printed. Words must be the same, runs of white space count as one space, and the
  order of the lines is free (shown outputs are cut). Numbers must agree within
  ``REL_TOL`` (6 %: the learned methods' spread across machines that docs/determinism.md measured,
  5.6e-2 at most; on the machine the page was made on they agree to every digit) or one unit of
  the shown number's last digit where it has decimals or is a percentage (a value on a rounding
  edge). Free: a bench run's id, and timings (the ``fit_seconds`` column of a table). A
  synopsis ``lcgym CMD [--opt ...]`` must name only options that ``lcgym CMD --help`` lists.
  Any other ``text`` block is not output, or is output a test makes: it carries a mark saying
  which (below).

Marks, an HTML comment on the line before a fence: ``<!-- docs-test: slow -->`` makes the page's
test ``slow`` (the commands take minutes; ``pytest -m slow tests/test_docs.py`` runs them);
``<!-- docs-test: emps -->`` puts ``DATA_EMPS.mat`` and ``DATA_EMPS_PULSES.mat`` in the folder
first, made from ``tests/test_diagnose_emps.py``'s simulated carriage (the real files are not in
the repository); ``<!-- docs-test: not-compared (why) -->`` before a ``text`` block: output that
is not compared (the EMPS page's, from the real files); ``<!-- docs-test: not-output (what it is) -->`` before a
``text`` block that is no command's output (equations, a file's text);
``<!-- docs-test: shown-by (tests/FILE.py) -->`` before output that a test produces and compares
with the page itself (a stopped bench's message: stopping one at a known cell needs a test).

``.ci/wheel_check`` runs the getting-started, diagnosis and own-machine pages again with lcgym
installed from its wheel in a fresh venv, outside the source tree (``LCGYM_DOCS_INSTALLED=1``:
repository paths are left as written, and lcgym must not come from the checkout).
"""

from __future__ import annotations

import os
import random
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [*sorted(DOCS.rglob("*.md")), ROOT / "README.md"]
BIN = Path(sys.executable).parent
# set by .ci/wheel_check: lcgym is an installed wheel, run away from the source tree (no paths into it)
INSTALLED = os.environ.get("LCGYM_DOCS_INSTALLED") == "1"
LANGUAGES = {"python", "bash", "text"}
MARK = re.compile(r"^<!-- docs-test: ([\w-]+)(?: \((.*)\))? -->$")
MARKS = {"slow", "emps", "not-compared", "not-output", "shown-by"}
FILE_BLOCK = re.compile(r"^# (\w+\.py)\b")
NUMBER = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")
RUN_ID = re.compile(r"\brun [0-9a-f]{12}\b")  # a bench run's random id (uuid4), compared as a number is
REPO_PATH = re.compile(r"(?<![\w./-])((?:lcgym|results|studies|scripts|benchmarks)/[\w./-]+)")


@dataclass
class Block:
    page: Path
    line: int  # of the opening fence, 1-based
    lang: str
    code: str
    marks: set[str] = field(default_factory=set)
    why: str = ""  # the mark's text in parentheses
    outputs: list[Block] = field(default_factory=list)  # for a bash block: the text blocks it shows

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def file_name(self) -> str | None:
        m = FILE_BLOCK.match(self.code) if self.lang == "python" else None
        return m.group(1) if m else None

    @property
    def installs(self) -> bool:
        return self.lang == "bash" and ("python3 -m venv" in self.code or "pip install" in self.code)


def blocks(page: Path) -> list[Block]:
    """The page's fenced blocks in order; each bash block with the text blocks that show its output."""
    lines = page.read_text().splitlines()
    out: list[Block] = []
    last_bash: Block | None = None
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("#") and not line.startswith("#!"):  # a heading ends a command's output
            last_bash = None
        if line.lstrip().startswith("```"):
            indent = len(line) - len(line.lstrip())
            lang = line.strip()[3:].strip()
            end = next(j for j in range(k + 1, len(lines)) if lines[j].strip() == "```")
            code = "\n".join(x[indent:] for x in lines[k + 1:end]) + "\n"
            prev = next((lines[j].strip() for j in range(k - 1, -1, -1) if lines[j].strip()), "")
            mark = MARK.match(prev)
            block = Block(page, k + 1, lang, code, {mark.group(1)} if mark else set(), (mark and mark.group(2)) or "")
            out.append(block)
            if lang == "bash":
                last_bash = block
            elif lang == "text" and last_bash is not None:
                last_bash.outputs.append(block)
            elif lang != "text":
                last_bash = None
            k = end + 1
            continue
        k += 1
    return out


ALL = [b for p in PAGES for b in blocks(p)]


REL_TOL = 0.06


def _normalized(line: str) -> str:
    return " ".join(NUMBER.sub("#", RUN_ID.sub("run #", line)).split())


def _numbers(line: str) -> list[str]:
    return NUMBER.findall(RUN_ID.sub("run #", line))


def _timing_columns(lines: list[str]) -> dict[int, int]:
    """Line index -> index of its number that is a timing: the last number of each row of a table
    whose header ends in ``fit_seconds``, up to the table's first blank line."""
    free, in_table = {}, False
    for i, line in enumerate(lines):
        if line.split()[-1:] == ["fit_seconds"]:
            in_table = True
        elif not line.strip():
            in_table = False
        elif in_table and _numbers(line):
            free[i] = len(_numbers(line)) - 1
    return free


def _agrees(shown: str, printed: str) -> bool:
    a, b = float(shown), float(printed)
    unit = 10.0 ** -len(shown.partition(".")[2]) if "." in shown else 0.0
    return abs(a - b) <= max(REL_TOL * abs(a), unit) + 1e-12 * abs(a)


def _line_matches(shown: str, printed: str, free: int | None) -> bool:
    if _normalized(shown) != _normalized(printed):
        return False
    pairs = list(zip(_numbers(shown), _numbers(printed), strict=True))
    percent = [m.end() < len(shown) and shown[m.end()] == "%" for m in NUMBER.finditer(RUN_ID.sub("run #", shown))]
    return all(k == free or _agrees(a, b) or (pct and abs(float(a) - float(b)) <= 1)
               for k, ((a, b), pct) in enumerate(zip(pairs, percent, strict=True)))


def _script(code: str) -> str:
    code = code.replace(".venv/bin/", f"{BIN}/")
    if INSTALLED:
        return code
    return REPO_PATH.sub(lambda m: str(ROOT / m.group(1)) if (ROOT / m.group(1)).exists() else m.group(1), code)


def _emps_files(folder: Path) -> None:
    """``DATA_EMPS.mat`` / ``DATA_EMPS_PULSES.mat`` of the benchmark's layout from the simulated
    carriage with the published asymmetric friction (two experiments, seeds 0 and 1)."""
    from test_diagnose_emps import ASYMMETRIC, CARRIAGE, GTAU, write_mat

    from lcgym import systems
    from lcgym.systems.urdf_plant import URDFPlant, random_references

    (folder / "carriage.urdf").write_text(CARRIAGE)
    carriage = systems.get(str(folder / "carriage.urdf"), joints=("x",))
    for name, seed in (("DATA_EMPS.mat", 0), ("DATA_EMPS_PULSES.mat", 1)):
        run = URDFPlant(carriage, effects=ASYMMETRIC, encoder_resolution=1e-6, seed=seed).run(
            random_references(carriage, n=1, duration=25.0, seed=seed))[0]
        write_mat(folder / name, run.t, run.pos[:, 0], run.ref[:, 0], run.u[:, 0] / GTAU)


def _run_bash(block: Block, folder: Path) -> str:
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", "MPLBACKEND": "Agg"}
    done = subprocess.run(["bash", "-euo", "pipefail", "-c", _script(block.code)], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, (f"{block.where}: exit status {done.returncode}\n{block.code}\n"
                                  f"{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return (done.stdout + done.stderr).replace(f"{ROOT}/", "")


def _check_output(block: Block, printed: str) -> None:
    """Each line a ``text`` block after ``block`` shows must be a line it printed (rules above)."""
    have: dict[str, list[str]] = {}
    for line in printed.splitlines():
        have.setdefault(_normalized(line), []).append(line)
    for shown in block.outputs:
        if "not-compared" in shown.marks:
            continue
        lines = shown.code.splitlines()
        free = _timing_columns(lines)
        missing = [x for i, x in enumerate(lines) if x.strip() and x.strip() != "..."
                   and not any(_line_matches(x, y, free.get(i)) for y in have.get(_normalized(x), []))]
        assert not missing, (f"{shown.where}: lines the page shows that {block.where} did not print "
                             f"(words, or numbers beyond {REL_TOL:.0%}):\n" + "\n".join(
                                 f"{x}\n  it printed: {' | '.join(have.get(_normalized(x), ['no line of these words']))}"
                                 for x in missing) + f"\n--- it printed:\n{printed[-4000:]}")


def run_page(page: Path, folder: Path, monkeypatch) -> None:
    if INSTALLED:
        import lcgym

        assert ROOT not in Path(lcgym.__file__).resolve().parents, f"lcgym imported from the source tree: {lcgym.__file__}"
    monkeypatch.chdir(folder)
    monkeypatch.syspath_prepend(str(folder))
    random.seed(0)
    np.random.seed(0)
    namespace = {"__name__": "__docs__"}
    for block in blocks(page):
        if block.lang == "python" and block.file_name:
            (folder / block.file_name).write_text(block.code)
        elif block.lang == "python":
            exec(compile(block.code, block.where, "exec"), namespace)
        elif block.lang == "bash" and not block.installs:
            if "emps" in block.marks:
                _emps_files(folder)
            _check_output(block, _run_bash(block, folder))


def _page_param(page: Path):
    runnable = [b for b in blocks(page) if b.lang == "python" or (b.lang == "bash" and not b.installs)]
    if not runnable:
        return None
    slow = any("slow" in b.marks for b in runnable)
    return pytest.param(page, id=str(page.relative_to(ROOT)), marks=[pytest.mark.slow] if slow else [])


@pytest.mark.parametrize("page", [p for p in map(_page_param, PAGES) if p is not None])
def test_page_code_runs_as_written(page, tmp_path, monkeypatch):
    run_page(page, tmp_path, monkeypatch)


def test_every_block_is_accounted_for():
    """Known languages only; file blocks used by the page; marks spelled right."""
    assert ALL, "no code blocks found"
    for b in ALL:
        assert b.lang in LANGUAGES, f"{b.where}: a block in {b.lang!r}; the tests know {sorted(LANGUAGES)}"
        assert b.marks <= MARKS, f"{b.where}: unknown mark {b.marks}"
        if b.file_name:
            module = b.file_name.removesuffix(".py")
            later = [c.code for c in blocks(b.page) if c.line > b.line and c.lang in ("bash", "python")]
            assert any(b.file_name in c or re.search(rf"\b{module}[:.]|import {module}\b", c) for c in later), \
                f"{b.where}: {b.file_name} is saved but no later block of the page runs or imports it"
    shown = {id(o) for b in ALL for o in b.outputs}
    for b in ALL:
        if b.lang != "text" or id(b) in shown or re.match(r"lcgym \w+ \[", b.code):
            continue
        assert b.marks & {"not-output", "shown-by"}, (
            f"{b.where}: a text block that is no command's output here: show the command that prints it "
            "in a bash block before it, or mark it not-output (what it is) or shown-by (tests/FILE.py)")
        if "shown-by" in b.marks:
            test = ROOT / b.why
            assert test.is_file() and b.page.name in test.read_text(), (
                f"{b.where}: shown-by names {b.why!r}, which must be a test file that reads {b.page.name}")
    assert [b for b in ALL if b.marks & {"slow"}], "no slow block: drop the mark's handling or mark one"
    slow_pages = {b.page for b in ALL if "slow" in b.marks}
    assert len(slow_pages) <= 4, f"keep the slow set small: {sorted(map(str, slow_pages))}"


def test_install_commands_are_the_ones_ci_runs():
    """The set-up commands are not run here: CI runs them (.ci/run), verbatim."""
    ci = [x.strip() for x in (ROOT / ".ci" / "run").read_text().splitlines()]
    test_line = next(x for x in ci if x.startswith("python3 -m venv") and "pytest" in x)
    main_job = test_line.replace('-e ".[test]"', "-e .").replace(".venv/bin/python -m pytest -q", ".venv/bin/lcgym bench --quick")
    commands = [x.strip() for b in ALL if b.installs for x in b.code.splitlines() if x.strip()]
    assert test_line in commands and main_job in commands
    for page in (ROOT / "README.md", DOCS / "getting-started.md"):
        shown = {x.strip() for b in blocks(page) if b.installs for x in b.code.splitlines()}
        assert {test_line, main_job} <= shown, f"{page.name}: the set-up commands differ from CI's"
    ci_parts = {_quiet(part) for line in ci for part in line.split(" && ")}
    for command in commands:
        assert command == main_job or all(_quiet(part) in ci_parts for part in command.split(" && ")), \
            f"{command!r} is shown as a set-up command but .ci/run does not run it"


def _quiet(command: str) -> str:
    """A command as CI's form of it is compared: without ``-q`` and ``--site-dir DIR``."""
    return " ".join(re.sub(r'--site-dir ("[^"]*"|\S+)', "", command).replace(" -q ", " ").split())


def test_synopses_name_only_real_options():
    for b in ALL:
        m = re.match(r"lcgym (\w+) \[", b.code) if b.lang == "text" else None
        if not m:
            continue
        helptext = subprocess.run([str(BIN / "lcgym"), m.group(1), "--help"], capture_output=True, text=True).stdout
        for option in set(re.findall(r"--[\w-]+", b.code)):
            assert option in helptext, f"{b.where}: lcgym {m.group(1)} has no option {option}"


def test_readme_fits_a_first_read():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) < 150
    for target in re.findall(r"\]\((docs/[^)#]+)", readme):
        assert (ROOT / target).is_file(), f"README links to {target}, which does not exist"


def test_the_comparison_is_loose_only_in_timings_run_ids_and_the_last_digit():
    printed = "  roll           0.0655   0.0165     -75%"
    assert _line_matches("  roll  0.0656  0.0164   -76%", printed, None)  # a last digit, a rounding edge
    assert _line_matches("  roll  0.0640  0.0170   -75%", printed, None)  # within the cross-machine spread
    assert not _line_matches("  roll  0.0855  0.0165   -75%", printed, None)  # a stale number
    assert not _line_matches("  roll  0.0655  0.0165   -65%", printed, None)
    assert not _line_matches("  pitch  0.0655  0.0165   -75%", printed, None)  # a word
    assert not _line_matches("  8 combinations", "  7 combinations", None)  # a count
    # the fit_seconds column is a timing, free; the other columns are not
    table = [" rank   method  RMS unit  fit_seconds", "    1 physical 0.09422  deg        0.341"]
    free = _timing_columns(table)
    assert _line_matches(table[1], "    1 physical 0.09422  deg        12.5", free[1])
    assert not _line_matches(table[1], "    1 physical 0.1942  deg        0.341", free[1])
    # a bench run's id is random: any other id reads the same, any other word does not
    assert _line_matches("run 2eb779fed591: 8 cells run", "run 43d154c221f1: 8 cells run", None)
    assert not _line_matches("run 2eb779fed591: 8 cells run", "ran 2eb779fed591: 8 cells run", None)
    urdf = "lcgym/systems/two_link/two_link.urdf"
    assert shlex.split(_script(f"x {urdf} y"))[1] == str(ROOT / urdf)


def test_the_test_count_on_the_tests_page_is_current(request):
    """docs/tests.md states how many tests ``python -m pytest -q`` runs; where this session runs every
    test file (the default selection), that count must be within 2 % of the tests it selected."""
    selected = request.session.items
    files = {Path(str(item.fspath)).name for item in selected}
    if files != {p.name for p in (ROOT / "tests").glob("test_*.py")} or request.config.getoption("markexpr") != "not slow":
        pytest.skip("a partial run: the page's count is of the whole default selection")
    stated = re.search(r"`python -m pytest -q` \(([\d,]+) tests", (DOCS / "tests.md").read_text())
    assert stated, "docs/tests.md no longer states the count as `python -m pytest -q` (N tests"
    count = int(stated.group(1).replace(",", ""))
    assert abs(count - len(selected)) <= 0.02 * len(selected), (
        f"docs/tests.md says {count} tests, the default selection has {len(selected)}: update the page")
