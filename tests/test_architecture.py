"""The pipeline's structure, checked rather than remembered (docs/architecture.md).

- Who may import whom: every package and top-level module of ``src/rwhonet`` has a
  row in :data:`ALLOWED`, the same table as docs/architecture.md's "Who may import
  whom"; an import outside it fails, and so does a unit missing from the table.
- No import cycle, between modules (lazy and type-checking imports included) or
  between the table's units.
- Every module a DVC stage imports (its entry script's import closure, lazy imports
  inside functions included) lies under one of the stage's ``deps`` in dvc.yaml, so
  changing it makes DVC re-run the stage. (Which params a stage reads is enforced at
  run time: ``rwhonet.runner.run`` hands a stage only the params dvc.yaml declares.)
- Every declared param exists in params.yaml.
- A package's docstring names its modules, and only modules that exist; every file
  docs/architecture.md names exists and holds the names it says it does.
- Nothing in src/ imports pipelines/.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import yaml

from rwhonet import paths

SRC = paths.ROOT / "src"
PACKAGE = "rwhonet"

# Who may import whom (docs/architecture.md keeps the same table): each unit of src/rwhonet
# (a package, or a module at the top) and the units it may import.
FOUNDATION = {"config", "contracts", "errors", "io", "libraries", "progress"}
ALLOWED: dict[str, set[str]] = {
    "contracts": set(),
    "errors": set(),
    "libraries": set(),
    "progress": set(),
    "paths": set(),
    "io": {"contracts"},
    "config": {"paths"},
    "geo": FOUNDATION - {"config"},
    "data": FOUNDATION | {"geo"},
    "features": FOUNDATION | {"data", "geo"},
    "sim": FOUNDATION | {"data", "geo"},
    "models": FOUNDATION | {"features"},
    "nav": FOUNDATION | {"features", "geo"},
    "evaluation": FOUNDATION | {"features", "geo", "nav"},
    "serve": FOUNDATION | {"data", "features", "geo", "models", "nav"},
    "report": FOUNDATION | {"evaluation", "paths"},
    "tracking": FOUNDATION | {"features", "paths", "serve"},
    "runner": FOUNDATION | {"paths", "tracking"},
    "stages": FOUNDATION
    | {"data", "evaluation", "features", "geo", "models", "nav", "paths", "report", "serve"}
    | {"sim", "tracking"},
    "cli": FOUNDATION
    | {"data", "evaluation", "features", "geo", "models", "nav", "paths", "report", "serve"}
    | {"tracking"},
}
PIPELINES_MAY_IMPORT = {"runner", "stages"}
DOMAIN = ("sim", "data", "geo", "features", "models", "nav", "evaluation", "serve")


def module_file(module: str) -> Path | None:
    """The source file of a ``rwhonet`` module (a package's ``__init__.py``), or None."""
    base = SRC.joinpath(*module.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def imports_of(file: Path, module: str | None) -> set[str]:
    """Every ``rwhonet`` module a file imports, at any depth of its code (lazy imports too)."""
    tree = ast.parse(file.read_text(encoding="utf-8"))
    package = module if file.name == "__init__.py" else (module or "").rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            # `from pkg import name`: name may be a submodule or an attribute of pkg.
            names = [base] + [f"{base}.{a.name}" for a in node.names]
        else:
            continue
        found |= {n for n in names if n == PACKAGE or n.startswith(PACKAGE + ".")}
    return {n for n in found if module_file(n) is not None}


def closure(entry: Path) -> set[Path]:
    """The files of every ``rwhonet`` module an entry script imports, transitively.

    Importing ``a.b.c`` runs ``a/__init__.py`` and ``a/b/__init__.py`` too, so they count.
    """
    todo = [(entry, None)]
    seen_modules: set[str] = set()
    files: set[Path] = set()
    while todo:
        file, module = todo.pop()
        for name in imports_of(file, module):
            parts = name.split(".")
            for i in range(1, len(parts) + 1):
                parent = ".".join(parts[:i])
                if parent not in seen_modules:
                    seen_modules.add(parent)
                    f = module_file(parent)
                    files.add(f)
                    todo.append((f, parent))
    return files


def stages() -> dict[str, dict]:
    return yaml.safe_load((paths.ROOT / "dvc.yaml").read_text())["stages"]


def entry_script(stage: dict) -> Path:
    script = next(w for w in stage["cmd"].split() if w.endswith(".py"))
    return paths.ROOT / script


def covered(file: Path, deps: list[str]) -> bool:
    rel = file.relative_to(paths.ROOT)
    return any(rel == Path(d) or Path(d) in rel.parents for d in deps)


@pytest.mark.parametrize("name", list(stages()))
def test_every_imported_module_is_a_declared_dependency(name):
    stage = stages()[name]
    deps = [d for d in stage.get("deps", []) if "${" not in d]
    entry = entry_script(stage)
    assert covered(entry, deps), f"stage {name}: its script {entry.name} is not in deps"
    missing = sorted(str(f.relative_to(paths.ROOT)) for f in closure(entry) if not covered(f, deps))
    assert not missing, (
        f"dvc.yaml stage {name} imports these but does not depend on them: {missing}"
    )


@pytest.mark.parametrize("name", list(stages()))
def test_declared_params_exist(name):
    params = yaml.safe_load((paths.ROOT / "params.yaml").read_text())
    for key in stages()[name].get("params", []):
        node = params
        for part in key.split("."):
            assert isinstance(node, dict) and part in node, f"{name}: params key {key} not found"
            node = node[part]


def test_the_closure_sees_lazy_imports():
    # stages/adapt.py imports the models only inside adapt_grid.
    files = closure(paths.ROOT / "pipelines" / "adapt.py")
    assert SRC / "rwhonet" / "models" / "adapt.py" in files
    assert SRC / "rwhonet" / "models" / "__init__.py" in files


def src_modules() -> dict[str, Path]:
    """Every module of src/rwhonet by dotted name (a package by its ``__init__.py``)."""
    out = {}
    for file in sorted((SRC / PACKAGE).rglob("*.py")):
        out[".".join(file.relative_to(SRC).with_suffix("").parts).removesuffix(".__init__")] = file
    return out


def unit_of(module: str) -> str | None:
    """The table's unit of a module: ``rwhonet.data.quality`` -> ``data``; None for the root."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def test_every_unit_has_a_row_in_the_table():
    units = {unit_of(m) for m in src_modules()} - {None}
    assert units == set(ALLOWED), (
        f"units without a row: {sorted(units - set(ALLOWED))}; "
        f"rows of units that do not exist: {sorted(set(ALLOWED) - units)}"
    )


def forbidden_imports(modules: dict[str, Path], unit: str) -> list[str]:
    """``"<module> imports <name>"`` for every import of ``unit``'s modules the table forbids."""
    bad = []
    for module, file in modules.items():
        if unit_of(module) != unit:
            continue
        for name in imports_of(file, module):
            target = unit_of(name)
            if target not in (None, unit) and target not in ALLOWED[unit]:
                bad.append(f"{module} imports {name}")
    return bad


@pytest.mark.parametrize("unit", sorted(ALLOWED))
def test_imports_follow_the_table(unit):
    bad = forbidden_imports(src_modules(), unit)
    assert not bad, f"{unit} may import only {sorted(ALLOWED[unit])}:\n" + "\n".join(bad)


def test_the_table_check_finds_a_forbidden_import(tmp_path):
    """A CLI module reaching into the stage layer, at the top, lazily and for type checking."""
    file = tmp_path / "bad.py"
    file.write_text(
        "from typing import TYPE_CHECKING\n"
        "from rwhonet.data import quality\n"
        "from rwhonet.report.tables import render_report\n"
        "if TYPE_CHECKING:\n"
        "    from rwhonet.stages.evaluate import Evaluation\n"
        "def run():\n"
        "    from rwhonet import runner\n",
        encoding="utf-8",
    )
    bad = forbidden_imports({"rwhonet.cli.bad": file}, "cli")
    assert sorted(bad) == [
        "rwhonet.cli.bad imports rwhonet.runner",
        "rwhonet.cli.bad imports rwhonet.stages.evaluate",
    ]


def test_pipelines_import_only_the_runner_and_the_stages():
    for file in sorted((paths.ROOT / "pipelines").glob("*.py")):
        used = {unit_of(n) for n in imports_of(file, None)} - {None}
        assert used <= PIPELINES_MAY_IMPORT, f"{file.name} imports {sorted(used)}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan), iteratively."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        component.append(top)
                        if top == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
            elif child not in graph:
                continue
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return found


def test_no_import_cycle_between_modules():
    graph = {m: imports_of(f, m) - {m} for m, f in src_modules().items()}
    assert not _cycles(graph), _cycles(graph)


def test_the_table_itself_has_no_cycle():
    assert not _cycles({u: set(a) for u, a in ALLOWED.items()})


def test_the_cycle_check_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_docs_hold_the_same_table():
    text = (paths.ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## Who may import whom", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0].startswith("`"):
            names = set(re.findall(r"`([a-z_]+)`", cells[1]))
            if re.match(r"F\b", cells[1]):
                names |= FOUNDATION
            rows[cells[0].strip("`")] = names
    assert rows == ALLOWED, {
        u: (rows.get(u), ALLOWED.get(u))
        for u in set(rows) | set(ALLOWED)
        if rows.get(u) != ALLOWED.get(u)
    }


def test_the_docs_name_only_modules_that_exist_and_what_they_hold():
    """docs/architecture.md answers "where is X" by file: each file it names exists, and the
    names given beside one (`evaluation/selection.py` (`recommend` ... `choose`)) are in it."""
    import importlib

    text = (paths.ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    named = set(re.findall(r"`([a-z_]+(?:/[a-z_]+)+\.py)`", text))
    missing = [
        f for f in named if not (paths.ROOT / f).is_file() and not (SRC / PACKAGE / f).is_file()
    ]
    assert not missing, f"docs/architecture.md names files that do not exist: {sorted(missing)}"
    pointers = re.findall(r"`([a-z_]+/[a-z_]+)\.py` \(([^)]*)\)", text)
    assert len(pointers) >= 3  # the window's scoring and cutting, the selection rule
    for module, beside in pointers:
        held = importlib.import_module(f"{PACKAGE}.{module.replace('/', '.')}")
        for name in re.findall(r"`([A-Za-z_]+)`", beside):
            assert hasattr(held, name), f"docs/architecture.md: {module}.py has no {name}"


@pytest.mark.parametrize(
    "package", sorted(p.parent.name for p in (SRC / PACKAGE).glob("*/__init__.py"))
)
def test_package_docstrings_name_their_modules_and_only_those(package):
    folder = SRC / PACKAGE / package
    doc = ast.get_docstring(ast.parse((folder / "__init__.py").read_text(encoding="utf-8"))) or ""
    modules = {f.stem for f in folder.glob("*.py") if not f.stem.startswith("_")}
    modules |= {d.name for d in folder.iterdir() if (d / "__init__.py").is_file()}
    # what the docstring lists as this package's modules: :mod: references, and the
    # ``name`` a bullet starts with
    listed = set(re.findall(rf":mod:`~?rwhonet\.{package}\.([a-z0-9_]+)`", doc))
    listed |= set(re.findall(r"^[-*] ``([a-z0-9_]+)``", doc, flags=re.M))
    mentioned = listed | set(re.findall(r"``([a-z0-9_]+)``", doc))
    assert listed <= modules, f"rwhonet.{package} docstring names {listed - modules}"
    assert modules <= mentioned, f"rwhonet.{package} docstring omits {modules - mentioned}"


def test_src_never_imports_pipelines():
    for file in sorted((SRC / PACKAGE).rglob("*.py")):
        tree = ast.parse(file.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom | ast.Import):
                names = [node.module or ""] if isinstance(node, ast.ImportFrom) else []
                names += [a.name for a in node.names]
                assert not any(n.startswith("pipelines") for n in names), file


def test_the_lock_file_holds_only_the_pipeline_s_stages():
    """DVC never prunes ``dvc.lock``: a renamed or removed stage would stay there, stale."""
    from dvc.repo import Repo

    with Repo(str(paths.ROOT)) as repo:
        names = {
            stage.addressing for stage in repo.index.stages if stage.path_in_repo == "dvc.yaml"
        }
    locked = set(yaml.safe_load((paths.ROOT / "dvc.lock").read_text())["stages"])
    assert locked <= names, (
        f"dvc.lock has stages dvc.yaml no longer defines: {sorted(locked - names)}"
    )
