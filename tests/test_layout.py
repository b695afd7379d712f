"""The package's layout: imports run one way, and no method, learner or diagnosis asks for a machine
by name.

The imports of every module of ``lcgym`` are read from its source (``ast``: module level and inside
functions, relative ones resolved). Each module belongs to a *unit*: its folder
(``lcgym/systems/ix/`` is ``systems.ix``), or itself for a top-level module (``data``, ``cli``, ...).
The graph of units must have no cycle, nor the graph of modules (two modules of one folder that
import each other), and every import must go down the layers

    cli -> leaderboard, diagnose, simulate -> methods -> systems -> envs
        -> physics, references, datasets -> data, metrics, provenance

(a unit may import its own layer's units where that is listed below, and any lower layer). The
machine packages are found by name at run time (``systems.get``: ``importlib``), not imported by
``systems``: that lookup is the registry, not an import edge. No method keeps a setting in a dict
(or a ``match``) keyed by a machine's name: the machine holds it (``System.settings``).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from lcgym import systems

ROOT = Path(__file__).resolve().parents[1] / "lcgym"

LAYERS = [
    {"cli"},
    {"leaderboard", "diagnose", "simulate"},
    {"methods"},  # one module or folder per method, and what they share
    {"systems", "systems.*"},  # systems.*: a machine's folder (systems/ix/, systems/two_link/, ...)
    {"envs"},
    {"physics", "references", "datasets", "logs"},
    {"data", "figures", "fitted", "metrics", "provenance", "user_code"},
]
SAME_LAYER = {  # imports allowed within one layer (unit -> units)
    "simulate": {"leaderboard"},
    "systems.*": {"systems"},  # a machine's folder uses what systems/ has for every machine
    "references": {"physics"},  # references_of differentiates the trials' references
}
METHOD_UNITS = ("methods", "diagnose", "leaderboard", "simulate")
MACHINE_NAMES = tuple(systems.BUILT_IN)


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _unit(module: str) -> str | None:
    """The unit of a module ``lcgym.x.y.z``; None for the root package ``lcgym`` itself."""
    parts = module.split(".")[1:]
    if not parts:
        return None
    if parts[0] == "systems" and len(parts) >= 2 and (ROOT / "systems" / parts[1]).is_dir():
        return f"systems.{parts[1]}"
    return parts[0]


def _imports(path: Path) -> list[tuple[str, int]]:
    """(imported lcgym module, line) of every import statement in a file."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names if a.name.startswith("lcgym")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not target.startswith("lcgym"):
                continue
            for alias in node.names:  # "from . import systems" imports the submodule lcgym.systems
                sub = f"{target}.{alias.name}"
                is_module = (ROOT.parent / sub.replace(".", "/")).with_suffix(".py").exists() or \
                    (ROOT.parent / sub.replace(".", "/")).is_dir()
                out.append((sub if is_module else target, node.lineno))
    return out


def _edges() -> dict[tuple[str, str], list[str]]:
    edges: dict[tuple[str, str], list[str]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        src = _unit(_module_name(path))
        for target, line in _imports(path):
            dst = _unit(target)
            if src is None or dst is None or src == dst:
                continue
            edges.setdefault((src, dst), []).append(f"{path.relative_to(ROOT.parent)}:{line}")
    return edges


def _pattern(unit: str) -> str:
    """The name LAYERS and SAME_LAYER give a unit: a machine's folder is ``systems.*``."""
    return "systems.*" if unit.startswith("systems.") else unit


def _layer(unit: str) -> int:
    for i, layer in enumerate(LAYERS):
        if _pattern(unit) in layer:
            return i
    raise AssertionError(f"unit {unit} is in no layer of this test: add it to LAYERS")


def _strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``graph``: its strongly connected components of two or more nodes
    (Tarjan's algorithm), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            part = stack[stack.index(v):]
            del stack[stack.index(v):]
            if len(part) > 1:
                out.append(sorted(part))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle_between_folders():
    edges = _edges()
    graph: dict[str, set[str]] = {}
    for a, b in edges:
        graph.setdefault(a, set()).add(b)
    circles = _strongly_connected(graph)
    where = [f"{a} -> {b} at {edges[(a, b)][0]}" for part in circles for a in part for b in part if (a, b) in edges]
    assert not circles, f"import cycles between folders {circles}: " + "; ".join(where)


def _module_graph() -> dict[str, set[str]]:
    """Module -> the lcgym modules it imports (at module level or inside functions)."""
    graph: dict[str, set[str]] = {}
    for path in sorted(ROOT.rglob("*.py")):
        src = _module_name(path)
        graph[src] = {target for target, _ in _imports(path) if target != src}
    return graph


KNOWN_MODULE_CIRCLES: list = []  # none: the IX plant is handed its System (static_model) instead of importing it


def test_no_import_circle_between_modules():
    """Within a folder too: two modules that import each other (even inside a function, as the
    leaderboard's page and report did) are one module in two files."""
    circles = _strongly_connected(_module_graph())
    assert circles == KNOWN_MODULE_CIRCLES, f"import circles between modules: {circles}"


def test_the_circle_finder_finds_a_circle():
    """Control for the test above: a circle through a function-level import, and one of three."""
    assert _strongly_connected({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert _strongly_connected({"x": {"y"}, "y": {"z"}, "z": {"x"}, "w": set()}) == [["x", "y", "z"]]
    assert _strongly_connected({"a": {"b"}, "b": set()}) == []


def test_imports_run_down_the_layers():
    bad = []
    for (a, b), where in sorted(_edges().items()):
        la, lb = _layer(a), _layer(b)
        if lb < la or (lb == la and _pattern(b) not in SAME_LAYER.get(_pattern(a), set())):
            bad.append(f"{a} -> {b} ({', '.join(where[:2])})")
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_the_graph_sees_a_known_edge():
    """Control: the parser finds the edges it must find (else the tests above could not fail)."""
    edges = _edges()
    assert ("leaderboard", "methods") in edges and ("systems.ix", "physics") in edges
    assert ("diagnose", "systems") in edges and ("methods", "systems") in edges


def _name_branches(path: Path, root: Path = ROOT.parent) -> list[str]:
    """Comparisons of anything with the string "ix" or "flexarm" (==, !=, in, not in)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            strings = [n.value for n in operands if isinstance(n, ast.Constant) and isinstance(n.value, str)]
            for n in operands:
                if isinstance(n, (ast.Tuple, ast.List, ast.Set)):
                    strings += [e.value for e in n.elts if isinstance(e, ast.Constant) and isinstance(e.value, str)]
            if any(s in MACHINE_NAMES for s in strings):
                out.append(f"{path.relative_to(root)}:{node.lineno}")
    return out


def test_no_method_imports_a_machine():
    """A learning method reaches a machine's own law through the plant (``plant.learning_law``), not
    by importing the machine's modules: no edge from ``methods`` to a machine's folder."""
    edges = _edges()
    into_machines = {k: v for k, v in edges.items() if k[0] == "methods" and k[1].startswith("systems.")}
    assert not into_machines, into_machines


def test_ilc_and_the_rbf_expert_learn_through_the_plant_contract_alone():
    """One learning law each: they ask the plant for the machine's law and branch neither on their
    base nor on what the machine has (its nominal structure, a law of its own)."""
    found = []
    for path in sorted(ROOT.glob("methods/ilc/*.py")) + sorted(ROOT.glob("methods/rbf_expert/*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Compare) and "self.base" in ast.unparse(node):
                found.append(f"{path.name}:{node.lineno} {ast.unparse(node)}")
            if isinstance(node, ast.Attribute) and node.attr in ("nominal", "nominal_", "learning_law") and \
                    ast.unparse(node.value) not in ("plant",):
                found.append(f"{path.name}:{node.lineno} {ast.unparse(node)}")
    assert not found, found


def test_a_system_is_a_rigid_body_model_of_at_most_12_fields_with_typed_attachments():
    import dataclasses

    from lcgym.systems.system import RigidBodyModel, System

    core = [f.name for f in dataclasses.fields(RigidBodyModel)]
    assert len(core) <= 12, core
    attached = [f for f in dataclasses.fields(System) if f.name not in core]
    loose = [f.name for f in attached if any(t in str(f.type).split(" | ") for t in ("object", "Callable", "Any"))]
    assert attached and not loose, loose


def test_every_built_in_plant_keeps_the_plant_contract():
    from lcgym import systems
    from lcgym.methods.ilc import ILCConfig
    from lcgym.systems.learning import LearningLaw
    from lcgym.systems.plant import Plant

    for name in systems.BUILT_IN:
        plant = systems.get(name).make_bench().plant
        assert isinstance(plant, Plant), name
        if name != "flexarm":  # the one built-in plant whose loads lag their motors
            with pytest.raises(ValueError, match="has no reference-offset channel"):
                plant.run_with_offset(None, None, None)
        for base in ("physical", "basic") if systems.get(name).nominal is not None else ("physical",):
            law = plant.learning_law(base, ILCConfig())
            assert isinstance(law, LearningLaw) and law.trials >= 1, (name, base)


def test_no_method_learner_or_diagnosis_branches_on_a_machine_name():
    found = [hit for unit in METHOD_UNITS for path in sorted(ROOT.glob(f"{unit}/**/*.py")) + sorted(ROOT.glob(f"{unit}.py"))
             for hit in _name_branches(path)]
    assert not found, f"branches on a machine's name: {found}"


def test_the_branch_finder_finds_a_branch(tmp_path):
    """Control for the test above."""
    p = tmp_path / "probe.py"
    p.write_text('def f(system):\n    return 1 if system == "flexarm" else 2\n\n\nx = "ix" in ("ix",)\n')
    assert len(_name_branches(p, tmp_path)) == 2


def _name_keys(path: Path, root: Path = ROOT.parent) -> list[str]:
    """Dicts keyed by a machine's name ({"ix": ...}, dict(ix=...)) and ``match`` arms on one
    (case "flexarm":): a method's per-machine setting kept away from its machine."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        keys = []
        if isinstance(node, ast.Dict):
            keys = [k.value for k in node.keys if isinstance(k, ast.Constant) and isinstance(k.value, str)]
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict":
            keys = [k.arg for k in node.keywords if k.arg]
        elif isinstance(node, ast.match_case):
            keys = [p.value.value for p in ast.walk(node.pattern)
                    if isinstance(p, ast.MatchValue) and isinstance(p.value, ast.Constant)]
        if any(k in MACHINE_NAMES for k in keys):
            out.append(f"{path.relative_to(root)}:{node.lineno if hasattr(node, 'lineno') else node.pattern.lineno}")
    return out


def test_no_method_keeps_a_setting_per_machine_name():
    """A method's setting for one machine lives with the machine (``System.settings``), so that a new
    machine is one folder and no method changes."""
    found = [hit for unit in METHOD_UNITS for path in sorted(ROOT.glob(f"{unit}/**/*.py")) + sorted(ROOT.glob(f"{unit}.py"))
             for hit in _name_keys(path)]
    assert not found, f"settings keyed by a machine's name: {found}"


def test_the_key_finder_finds_dicts_and_match_arms(tmp_path):
    """Control for the test above."""
    p = tmp_path / "probe.py"
    p.write_text('A = {"ix": 1.0}\nB = dict(flexarm=2)\n\n\ndef f(name):\n    match name:\n'
                 '        case "ix":\n            return 1\n    return {"other": 3}\n')
    assert len(_name_keys(p, tmp_path)) == 3


def test_every_cached_kernel_is_keyed_by_the_sources_it_calls():
    """Every numba kernel of lcgym caches under ``~/.cache/lcgym/numba/<hash of its sources>``
    (``physics.compiled.cache_dir``), not in numba's default ``__pycache__``, which watches the
    kernel's own file only: an edited equation in a file it calls would run stale machine code."""
    import importlib
    import os
    import pkgutil

    import numba.core.registry

    import lcgym

    root = os.path.join(os.environ.get("XDG_CACHE_HOME", os.path.expanduser("~/.cache")), "lcgym", "numba")
    seen, stale = 0, []
    for info in pkgutil.walk_packages(lcgym.__path__, "lcgym."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            cache = getattr(obj, "_cache", None)
            if isinstance(obj, numba.core.registry.CPUDispatcher) and hasattr(cache, "_cache_path"):
                seen += 1
                if not cache._cache_path.startswith(root):
                    stale.append(f"{info.name}.{name}: {cache._cache_path}")
    assert seen > 10 and not stale, stale
    import numba

    assert numba.config.CACHE_DIR == _numba_default_cache_dir(), "a module left numba's cache folder set"


def _numba_default_cache_dir() -> str:
    return subprocess.run([sys.executable, "-c", "import numba; print(numba.config.CACHE_DIR)"], capture_output=True,
                          text=True, check=True).stdout.strip()


def test_one_module_sets_numbas_cache_folder():
    """``physics.compiled.Kernels`` is the one place that sets numba's cache folder: every module
    compiles its kernels with it (``njit = Kernels(__file__, ...)``), none sets it itself."""
    package = Path(__file__).resolve().parents[1] / "lcgym"
    setting = sorted(str(p.relative_to(package)) for p in package.rglob("*.py") if "config.CACHE_DIR =" in p.read_text())
    assert setting == ["physics/compiled.py"], setting
    direct = sorted(str(p.relative_to(package)) for p in package.rglob("*.py") if "numba.njit(" in p.read_text())
    assert direct == ["physics/compiled.py"], f"compile with physics.compiled.Kernels, not numba.njit: {direct}"


LEADERBOARD_VIEWS = ("lcgym.leaderboard.store", "lcgym.leaderboard.report", "lcgym.leaderboard.page",
                     "lcgym.leaderboard.plots", "lcgym.leaderboard.browser")
"""The leaderboard's reading side: what it shows comes from the results rows (each bench declares
its signals, labels and units there), not from the machines."""


def _machines_loaded(modules: tuple[str, ...]) -> list[str]:
    """The machine modules (under ``lcgym.systems`` beyond its registry and ``System``) and pinocchio
    that importing ``modules`` loads, in a fresh interpreter."""
    code = ("import sys\n" + "".join(f"import {m}\n" for m in modules)
            + "print('\\n'.join(m for m in sys.modules if (m.startswith('lcgym.systems.') and m != 'lcgym.systems.system')"
              " or m.split('.')[0] == 'pinocchio'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    return sorted(out.split())


def test_importing_the_leaderboard_loads_no_machine():
    assert _machines_loaded(LEADERBOARD_VIEWS) == []


def test_the_machine_finder_finds_a_machine():
    """Control for the test above."""
    assert "lcgym.systems.ix" in _machines_loaded(("lcgym.leaderboard.page", "lcgym.systems.ix"))


METHOD_DRIVERS = ("leaderboard/*.py", "simulate.py", "cli.py", "methods/protocol.py", "methods/bases.py",
                  "methods/safeguard.py")
"""The modules that build and run methods: they read the contract (``protocol.Controller``), never
ask a method what it has."""
WRAPPER = {"UserMethod", "_wrapped", "_load_class"}
"""Where a user's class that is no ``Controller`` is asked once what it has, and wrapped."""
NOT_METHODS = {"os", "signal", "process_executor", "module", "datasets"}
"""Objects the drivers may ask: the platform, loky, a user's module, the datasets' readers."""


def _probes(path: Path, root: Path = ROOT.parent) -> list[str]:
    """``getattr``/``hasattr`` calls outside ``WRAPPER`` on anything but ``NOT_METHODS``."""
    out = []

    def visit(node, inside: bool) -> None:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)) and node.name in WRAPPER:
            inside = True
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr")
                and not inside and not (isinstance(node.args[0], ast.Name) and node.args[0].id in NOT_METHODS)):
            out.append(f"{path.relative_to(root)}:{node.lineno}")
        for child in ast.iter_child_nodes(node):
            visit(child, inside)

    visit(ast.parse(path.read_text(), str(path)), False)
    return out


def test_no_driver_asks_a_method_what_it_has():
    found = [hit for pattern in METHOD_DRIVERS for path in sorted(ROOT.glob(pattern)) for hit in _probes(path)]
    assert not found, f"getattr/hasattr on a method (declare the attribute on protocol.Controller): {found}"


def test_the_probe_finder_finds_a_probe(tmp_path):
    """Control for the test above."""
    p = tmp_path / "probe.py"
    p.write_text('def f(controller, os):\n    return getattr(controller, "cost_", None), hasattr(os, "x")\n\n\n'
                 'class UserMethod:\n    def g(self):\n        return getattr(self.inner, "note_", "")\n')
    assert _probes(p, tmp_path) == ["probe.py:2"]
