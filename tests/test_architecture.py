"""The layering of DESIGN.md, checked on the source: figures live in ``actuator_design/viz`` (the only
importer of matplotlib), ``io`` writes files and knows nothing of plots, ``viz`` never solves, and
the command line's solve path does not load matplotlib at all."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "actuator_design"

#: Files outside viz/ still allowed to import matplotlib: removed when the calibration package lands.
MATPLOTLIB_EXCEPTIONS: set = set()

#: What viz/ must never import: the machinery that solves (viz draws results, it never solves).
SOLVING_MODULES = ("equilibrium.pipeline", "equilibrium.single", "equilibrium.solver", "equilibrium.acceptance",
                   "equilibrium.accuracy", "analysis", "inverse", "robust", "hardware", "schedules", "continuation",
                   "contact.equilibrium", "contact.self_solve", "contact.path", "contact.design", "transcription",
                   "study")


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path.relative_to(PACKAGE), ast.parse(path.read_text(encoding="utf-8"), str(path))


def _imported(tree, relative: Path):
    """Absolute dotted names of everything ``tree`` imports (relative imports resolved), including
    ``__import__("x")`` and ``importlib.import_module("x")`` with a literal name."""
    package = ["actuator_design", *relative.parent.parts]
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                prefix = ".".join(base + ([node.module] if node.module else []))
            else:
                prefix = node.module
            names.append(prefix)
            names += [f"{prefix}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            func = node.func
            name = func.id if isinstance(func, ast.Name) else getattr(func, "attr", None)
            if name in ("__import__", "import_module"):
                names.append(node.args[0].value)
    return names


def _is(name: str, module: str) -> bool:
    return name == module or name.startswith(module + ".")


def test_the_scan_sees_relative_and_dynamic_imports():
    tree = ast.parse("from ..viz.style import png_bytes\nfrom . import viz\n"
                     "import importlib\nimportlib.import_module('matplotlib.figure')\n")
    names = _imported(tree, Path("cli/solve.py"))
    assert "actuator_design.viz.style" in names and "actuator_design.cli.viz" in names
    assert "matplotlib.figure" in names


def test_matplotlib_is_imported_only_under_viz():
    offenders = []
    for rel, tree in _modules():
        if rel.parts[0] == "viz" or str(rel) in MATPLOTLIB_EXCEPTIONS:
            continue
        offenders += [f"{rel}: {n}" for n in _imported(tree, rel) if _is(n, "matplotlib")]
    assert not offenders, "matplotlib imported outside actuator_design/viz:\n" + "\n".join(offenders)


def _module_name(rel: Path) -> str:
    parts = ["actuator_design", *rel.with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_io_knows_nothing_of_plots():
    """Nothing the io/ room imports, directly or through other modules of the package, is viz or
    matplotlib (its writers save figures as bytes the caller drew)."""
    graph = {_module_name(rel): _imported(tree, rel) for rel, tree in _modules()}
    seen, reached = set(), []
    todo = [m for m in graph if m == "actuator_design.io" or m.startswith("actuator_design.io.")]
    while todo:
        mod = todo.pop()
        if mod in seen:
            continue
        seen.add(mod)
        for name in graph.get(mod, ()):
            reached.append((mod, name))
            # `from .x import y` names a module x or a name y in it: follow whichever is a module
            todo += [n for n in (name, name.rpartition(".")[0]) if n in graph]
    bad = sorted({f"{m} -> {n}" for m, n in reached
                  if _is(n, "matplotlib") or _is(n, "actuator_design.viz")})
    assert not bad, "io reaches plots:\n" + "\n".join(bad)


def test_viz_never_reaches_for_the_solvers():
    offenders = []
    for rel, tree in _modules():
        if rel.parts[0] != "viz":
            continue
        for n in _imported(tree, rel):
            if any(_is(n, f"actuator_design.{m}") for m in SOLVING_MODULES):
                offenders.append(f"{rel}: {n}")
    assert not offenders, "viz imports solving code:\n" + "\n".join(offenders)


def test_viz_package_marker_is_the_agreed_single_line():
    # another branch creates the identical file; an exact match keeps the merge clean
    assert (PACKAGE / "viz" / "__init__.py").read_text() == \
        '"""Figures: pure functions of results; the only importer of matplotlib."""\n'


def _run_python(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("MPLBACKEND", None)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=ROOT, timeout=300)


def test_importing_the_cli_and_the_solver_does_not_load_matplotlib():
    p = _run_python("import sys\n"
                    "import actuator_design.cli.main as m\n"
                    "m.build_parser(only='solve')\n"
                    "import actuator_design.equilibrium.pipeline, actuator_design.io.save\n"
                    "print('matplotlib' in sys.modules)")
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "False"


def test_the_solve_command_without_out_does_not_load_matplotlib():
    p = _run_python("import sys\n"
                    "from actuator_design.cli.main import main\n"
                    "code = main(['solve', '--h', '0.5', '--json'])\n"
                    "print('matplotlib' in sys.modules, code, file=sys.stderr)")
    assert p.stderr.strip().splitlines()[-1] == "False 0", p.stderr


def test_the_scene_and_saving_it_load_no_casadi_scipy_or_matplotlib():
    """The model's scene and ``io.save`` sit below physics: building or saving a scene costs no
    CasADi, SciPy or matplotlib import (a module-level import of physics there would)."""
    p = _run_python("import sys\n"
                    "import actuator_design.model.scene, actuator_design.io.save\n"
                    "print(sorted(m for m in ('casadi', 'scipy', 'matplotlib') if m in sys.modules))")
    assert p.returncode == 0 and p.stdout.strip() == "[]", p.stdout + p.stderr


@pytest.mark.parametrize("argv", [["--version"], ["--help"]])
def test_version_and_help_import_no_command_module(argv):
    """Start-up (issue 21): ``--version`` and ``--help`` import no command module (and so neither
    CasADi nor SciPy), and ``--help`` still lists every command with its one-line HELP."""
    p = _run_python("import sys, contextlib, io\n"
                    "from actuator_design.cli.main import main, COMMANDS\n"
                    "buf = io.StringIO()\n"
                    "with contextlib.redirect_stdout(buf):\n"
                    f"    code = main({argv!r})\n"
                    "heavy = [m for m in ('casadi', 'scipy') if m in sys.modules]\n"
                    "cmds = [m for m in sys.modules if m.startswith('actuator_design.cli.')\n"
                    "        and m.rsplit('.', 1)[1] in COMMANDS]\n"
                    "print(code, heavy, cmds, file=sys.stderr)\n"
                    "print(buf.getvalue())")
    assert p.stderr.strip().splitlines()[-1] == "0 [] []", p.stderr
    if argv == ["--help"]:
        import importlib

        from actuator_design.cli.main import COMMANDS
        for name in COMMANDS:
            first_words = " ".join(importlib.import_module(f"actuator_design.cli.{name}").HELP.split()[:3])
            assert first_words in " ".join(p.stdout.split()), name


#: The package root holds the face and leaf utilities only; everything else lives in a room
#: (docs/guide/layout.md). Issue 18: no folder holds more than ~15 modules (its ``__init__.py`` and
#: a ``__main__.py`` not counted); a large room keeps its parts in sub-folders (cli/design/).
ROOT_MODULES = {"__init__.py", "forked.py", "parallel.py"}
MOST_MODULES_A_FOLDER = 15


def test_the_root_holds_the_face_and_leaves_and_no_folder_is_a_hall():
    assert {p.name for p in PACKAGE.glob("*.py")} == ROOT_MODULES
    halls = {}
    for folder in sorted({p.parent for p in PACKAGE.rglob("__init__.py")} - {PACKAGE}):
        count = len([p for p in folder.glob("*.py") if p.name not in ("__init__.py", "__main__.py")])
        if count > MOST_MODULES_A_FOLDER:
            halls[folder.relative_to(PACKAGE).as_posix()] = count
    assert not halls, f"folders over {MOST_MODULES_A_FOLDER} modules: {halls}"


def test_the_leaves_at_the_root_import_nothing_from_the_rooms():
    for name in ROOT_MODULES - {"__init__.py"}:
        rel = Path(name)
        tree = ast.parse((PACKAGE / rel).read_text(encoding="utf-8"))
        rooms = [n for n in _imported(tree, rel) if _is(n, "actuator_design")
                 and not any(_is(n, f"actuator_design.{leaf[:-3]}") for leaf in ROOT_MODULES)]
        assert not rooms, name


def _import_time_nodes(body):
    """The nodes of ``body`` that run when the module is imported: not a function's body, but its
    decorators and default values, and a class's own statements."""
    for stmt in body:
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for part in [*stmt.decorator_list, *stmt.args.defaults, *[d for d in stmt.args.kw_defaults if d]]:
                yield from ast.walk(part)
        elif isinstance(stmt, ast.ClassDef):
            for part in [*stmt.decorator_list, *stmt.bases, *stmt.keywords]:
                yield from ast.walk(part)
            yield from _import_time_nodes(stmt.body)
        else:
            yield from ast.walk(stmt)


def _runtime_imports(tree, relative: Path, modules, top_level_only: bool = False, lazy=None):
    """The package modules ``tree`` imports at run time (function-local imports included, an
    ``if TYPE_CHECKING:`` block's not): ``from pkg import sub`` is the module pkg.sub, and pkg
    itself only for a name of its own; ``import_module("x")`` with a literal name counts."""
    typing_only = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and ast.unparse(node.test) in ("TYPE_CHECKING", "typing.TYPE_CHECKING"):
            typing_only |= {id(n) for part in node.body for n in ast.walk(part)}
    package = ["actuator_design", *relative.parent.parts]
    found = []
    nodes = list(_import_time_nodes(tree.body)) if top_level_only else ast.walk(tree)
    for node in nodes:
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - (node.level - 1)] if node.level else []
            prefix = ".".join(base + ([node.module] if node.module else []))
            for a in node.names:  # a submodule; a lazy face's name: its home; else the package itself
                home = (lazy or {}).get(prefix, {}).get(a.name)
                found.append(f"{prefix}.{a.name}" if f"{prefix}.{a.name}" in modules else home or prefix)
                if home:
                    found.append(f"{prefix}.__init__")  # (its module-level code runs first)
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str) \
                and getattr(node.func, "attr", getattr(node.func, "id", None)) in ("__import__", "import_module"):
            found.append(node.args[0].value)
    # importing a.b.c runs the module-level code of a/__init__ and a/b/__init__ first ("a#init",
    # "a.b#init"; a module's own packages are already running when it is imported)
    own = {".".join(package[:i]) for i in range(1, len(package) + 1)}
    out = set()
    for name in found:
        while name and name not in modules and not name.endswith(".__init__"):
            name = name.rpartition(".")[0]
        if name.endswith(".__init__"):
            name = name[:-len(".__init__")]
            if name not in own:
                out.add(name + "#init")
        elif name:
            out.add(name)
        parent = name.rpartition(".")[0]
        while parent:
            if parent in modules and parent not in own:
                out.add(parent + "#init")
            parent = parent.rpartition(".")[0]
    return out


def _import_graph():
    """Module → the package modules it imports at run time, plus the imports by computed name: the
    registries' (the shipped extra terms, physics/registry.py; the built-in analyses,
    analysis/registry.py ``BUILTIN``) and a lazy face's name (:func:`_lazy_homes`)."""
    trees = dict(_modules())
    modules = {_module_name(rel) for rel in trees}
    lazy = _lazy_homes()
    graph = {_module_name(rel): _runtime_imports(tree, rel, modules, lazy=lazy) - {_module_name(rel)}
             for rel, tree in trees.items()}
    for rel, tree in trees.items():  # a package's module-level code (what importing a submodule runs)
        if rel.name == "__init__.py":
            graph[_module_name(rel) + "#init"] = _runtime_imports(tree, rel, modules, top_level_only=True,
                                                                   lazy=lazy)
    graph["actuator_design.physics.registry"] |= {
        m for m in modules if m.startswith("actuator_design.physics.extra_terms.")}
    from actuator_design.analysis.registry import BUILTIN
    graph["actuator_design.analysis.registry"] |= {f"actuator_design.{m}" for m in BUILTIN.values()}
    return graph


#: the packages whose ``__init__`` defines ``__getattr__`` (a lazy face, PEP 562)
LAZY_FACES = ("actuator_design", "actuator_design.calibration", "actuator_design.config", "actuator_design.physics",
              "actuator_design.study")


def _lazy_homes():
    """The lazy faces (PEP 562): package → {public name: the module its first use imports}; a root
    name whose home is itself a lazy face is followed through to its module."""
    import actuator_design
    import actuator_design.calibration
    import actuator_design.config
    import actuator_design.study
    from actuator_design.physics import TERM_CLASSES

    homes = {"actuator_design.study": {n: "actuator_design.study.runner" for n in actuator_design.study.__all__}}
    homes["actuator_design.physics"] = {n: f"actuator_design.physics.{m}" for n, m in TERM_CLASSES.items()}
    for package in (actuator_design.calibration, actuator_design.config):
        homes[package.__name__] = {n: m if "." in m else f"{package.__name__}.{m}"
                                  for n, m in package._HOME.items()}
    homes["actuator_design"] = {n: homes.get(f"actuator_design.{m}", {}).get(attr, f"actuator_design.{m}")
                                for n, (m, attr) in actuator_design._EXPORTS.items()}
    return homes


def test_every_lazy_face_is_known_to_the_cycle_scan():
    faces = {_module_name(rel) for rel, tree in _modules() if rel.name == "__init__.py"
             and any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in tree.body)}
    assert faces == set(LAZY_FACES)


def test_a_lazy_name_is_an_import_of_its_home_also_from_a_package_init():
    """``from pkg import name`` of a lazy face is an edge to the name's home module, in a module
    and in a package's module-level code; the root's names reach through calibration's face."""
    homes = _lazy_homes()
    assert homes["actuator_design"]["prepare_fit"] == "actuator_design.calibration.solve"
    modules = {"actuator_design", "actuator_design.config", "actuator_design.config.model", "actuator_design.model"}
    tree = ast.parse("from ..config import load_config\n")
    found = _runtime_imports(tree, Path("model/__init__.py"), modules, top_level_only=True, lazy=homes)
    assert found == {"actuator_design.config.model", "actuator_design.config#init"}


def _cycles(graph):
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root), on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w), on_stack.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_cycle_finder_finds_a_ring_and_a_pair():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"e"}, "e": {"d", "a"}, "f": set()}
    assert sorted(_cycles(graph)) == [["a", "b", "c"], ["d", "e"]]


def test_the_package_has_no_import_cycles():
    """No module imports (at run time, function-local imports included) one that imports it back,
    directly or round a ring (issue 18). Checked between modules, not between rooms."""
    cycles = _cycles(_import_graph())
    assert not cycles, "import cycles:\n" + "\n".join(" ↔ ".join(c) for c in cycles)


def test_the_import_scan_counts_function_local_imports_and_not_annotation_only_ones():
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..model.scene import Scene\n"
                     "def f():\n    from ..physics import registry\n    from . import follow\n")
    modules = {"actuator_design.model.scene", "actuator_design.physics.registry",
               "actuator_design.continuation.follow", "actuator_design.physics", "actuator_design.continuation"}
    assert _runtime_imports(tree, Path("continuation/x.py"), modules) == {
        "actuator_design.physics.registry", "actuator_design.physics#init", "actuator_design.continuation.follow"}


#: Third-party modules a function may import on first use, because importing them costs start-up
#: time every command would pay (CasADi ~0.3 s, scipy.optimize ~0.1 s, pint, magpylib, xarray) or
#: because they are optional (dask's distributed, pyarrow). Everything else is imported at the top.
LAZY_THIRD_PARTY = ("casadi", "scipy", "matplotlib", "tqdm", "magpylib", "pint", "xarray", "distributed",
                    "pyarrow", "threadpoolctl")


def _function_local_imports(tree):
    """(line, dotted module) of every import statement inside a function body."""
    found = []

    def visit(node, in_function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(child, True)
            elif isinstance(child, (ast.Import, ast.ImportFrom)) and in_function:
                names = [child.module] if isinstance(child, ast.ImportFrom) else [a.name for a in child.names]
                found.extend((child.lineno, name or "") for name in names)
            else:
                visit(child, in_function)
    visit(tree, False)
    return found


def test_function_local_imports_are_only_for_start_up_time():
    """Issue 18: with no import cycles left, a module imports the package's modules at its top.
    Only the command line (one module per subcommand, loaded on demand), the lazy faces
    (``__init__``) and figures (viz/, drawn on demand) import inside functions, plus the heavy or
    optional third-party modules of LAZY_THIRD_PARTY."""
    offenders = []
    for rel, tree in _modules():
        if rel.parts[0] == "cli" or rel.name == "__init__.py":
            continue
        for line, name in _function_local_imports(tree):
            if _is(name, "actuator_design.viz") or name.split(".")[0] in LAZY_THIRD_PARTY:
                continue
            offenders.append(f"{rel}:{line}: {name}")
    assert not offenders, "function-local imports to move to the top:\n" + "\n".join(offenders)


def test_the_local_import_scan_sees_nested_functions_and_methods():
    tree = ast.parse("import os\nclass A:\n    def f(self):\n        def g():\n            from x.y import z\n"
                     "        import numpy\n")
    assert _function_local_imports(tree) == [(5, "x.y"), (6, "numpy")]
