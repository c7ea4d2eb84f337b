"""The pipeline's structure, checked rather than remembered (docs/architecture.md).

- Every module a DVC stage imports (its entry script's import closure, lazy imports
  inside functions included) lies under one of the stage's ``deps`` in dvc.yaml, so
  changing it makes DVC re-run the stage. (Which params a stage reads is enforced at
  run time: ``rwhonet.runner.run`` hands a stage only the params dvc.yaml declares.)
- Every declared param exists in params.yaml.
- Domain packages never import the stage layer, the project paths or MLflow tracking,
  and nothing in src/ imports pipelines/.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
import yaml

from rwhonet import paths

SRC = paths.ROOT / "src"
PACKAGE = "rwhonet"
DOMAIN = ("sim", "data", "geo", "features", "models", "evaluation", "serve", "nav")
INFRA = ("rwhonet.paths", "rwhonet.runner", "rwhonet.stages", "rwhonet.tracking", "pipelines")


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


@pytest.mark.parametrize("package", DOMAIN)
def test_domain_packages_stay_below_the_stage_layer(package):
    for file in sorted((SRC / PACKAGE / package).rglob("*.py")):
        module = ".".join(file.relative_to(SRC).with_suffix("").parts).removesuffix(".__init__")
        bad = sorted(
            n
            for n in imports_of(file, module)
            if any(n == i or n.startswith(i + ".") for i in INFRA)
        )
        assert not bad, f"{file.relative_to(paths.ROOT)} imports {bad}"


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
