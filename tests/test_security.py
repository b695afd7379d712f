"""Security: lcgym never unpickles what it did not write unless asked, never evaluates or runs a
user's string, and treats file names with shell syntax as plain names. (The report's HTML
escaping: tests/test_bench.py::test_report_pages_escape_strings.)"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "lcgym"

# (module path, function) pairs allowed to load a stable-baselines3 zip (pickled objects):
# RLFeedforward.load_model, called by learn only on its own cache after the SHA-256 check.
SB3_LOADERS = {("methods/rl.py", "load_model")}


def _calls(tree: ast.AST):
    """(call node, enclosing function name) for every call in a module."""
    def visit(node, func):
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef) else func
            if isinstance(child, ast.Call):
                yield child, func
            yield from visit(child, name)

    yield from visit(tree, "<module>")


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    if isinstance(node, ast.Call):
        return _dotted(node.func) + "()"
    return "?"


def _keyword(call: ast.Call, name: str):
    for k in call.keywords:
        if k.arg == name:
            return k.value.value if isinstance(k.value, ast.Constant) else "<expr>"
    return None


def unsafe_calls() -> list[str]:
    """Every call in lcgym that could unpickle or execute foreign data, outside the allowed places."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        for call, func in _calls(ast.parse(path.read_text())):
            name = _dotted(call.func)
            where = f"{rel}:{call.lineno} ({func}): {name}"
            last = name.rsplit(".", 1)[-1]
            if name in ("eval", "exec", "os.system", "os.popen") or last in ("read_pickle", "loads") and "json" not in name:
                found.append(where)
            elif name.startswith(("pickle.", "cloudpickle.", "dill.", "marshal.")) or last == "Unpickler":
                found.append(where)
            elif name == "torch.load" and _keyword(call, "weights_only") is not True:
                found.append(where)
            elif name in ("np.load", "numpy.load") and _keyword(call, "allow_pickle") not in (None, False):
                found.append(where)
            elif name.startswith("subprocess.") and _keyword(call, "shell") not in (None, False):
                found.append(where)
            elif last == "load" and "_algorithm_class" in name and (rel, func) not in SB3_LOADERS:
                found.append(where)
    return found


@pytest.mark.bad_input
def test_no_unpickling_or_evaluation_outside_the_allowed_places():
    assert unsafe_calls() == []


def test_the_scan_would_catch_them(tmp_path, monkeypatch):
    """The scan is not vacuous: planted unsafe calls are found."""
    planted = tmp_path / "lcgym"
    (planted / "methods").mkdir(parents=True)
    (planted / "methods" / "bad.py").write_text(
        "import pickle, torch, numpy as np, subprocess\n"
        "def f(p):\n"
        "    pickle.load(open(p, 'rb'))\n"
        "    torch.load(p)\n"
        "    np.load(p, allow_pickle=True)\n"
        "    subprocess.run(p, shell=True)\n"
        "    eval(p)\n"
        "    _algorithm_class('ppo').load(p)\n"
        "    torch.load(p, weights_only=True)\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", planted)
    assert len(unsafe_calls()) == 6


@pytest.mark.bad_input
@pytest.mark.parametrize("name", ["run; touch PWNED.csv", "$(touch PWNED).csv", "`touch PWNED`.csv",
                                  "__import__('os').system('touch PWNED').csv"])
def test_file_names_with_shell_or_python_syntax_are_only_names(tmp_path, name):
    proc = subprocess.run([sys.executable, "-m", "lcgym.cli", "diagnose", name, "--system", "ix"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0 and name in proc.stderr, proc.stderr
    assert not (tmp_path / "PWNED").exists() and not (tmp_path / "PWNED.csv").exists()
