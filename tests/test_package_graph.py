"""The packages import one way (plantlod/__init__.py):

    lsys -> sim -> compare -> simplify -> {scene, export} -> plantlod (the API) -> cli

and `formats` (bytes in and out) imports nothing above `lsys`. Read from the
source with `ast`, every import of every module, deferred ones inside functions
included: a new edge against the direction, or any cycle between packages, fails.
"""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parents[1]
FOLDERS = {"lsys": "lsys", "sim": "sim", "compare": "compare", "simplify": "simplify",
           "scene": "scene",
           "export": "export", "formats": "formats", "api": "plantlod", "cli": "cli"}
RANK = {"lsys": 0, "formats": 0, "sim": 1, "compare": 2, "simplify": 3, "scene": 4, "export": 4,
        "api": 5, "cli": 6}
# plantlod.compare and plantlod.simplify are also the functions of those names: each
# package's __call__ hands the call to the API, the one upward import allowed, in that
# file only (so a path, a text or an LSystem is read the same whichever way it is reached).
CALLABLE_PACKAGE_SHIMS = {("compare", "api", "compare/__init__.py"),
                          ("simplify", "api", "simplify/__init__.py")}
# formats sits beside lsys: it may read lsys' Tree and errors, nothing else above it
ALLOWED_FROM_FORMATS = {"lsys"}


def _package_of(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "plantlod":
        return None
    if len(parts) == 1 or parts[1] in ("api",):
        return "api"
    return parts[1] if parts[1] in RANK else None


def edges() -> set[tuple[str, str, str]]:
    """(importing package, imported package, where) for every cross-package import."""
    out = set()
    for package, folder in FOLDERS.items():
        for path in sorted((ROOT / folder).glob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
            for node in ast.walk(tree):
                targets = []
                if isinstance(node, ast.Import):
                    targets = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
                for target in targets:
                    other = _package_of(target)
                    if other and other != package:
                        out.add((package, other, f"{folder}/{path.name}:{node.lineno}"))
    return out


def test_imports_go_one_way():
    bad = []
    for source, target, where in sorted(edges()):
        if source == "formats":
            if target not in ALLOWED_FROM_FORMATS:
                bad.append(f"{where}: formats imports {target}")
        elif target == "formats":
            continue                    # every package may read and write bytes
        elif (source, target, where.split(":")[0]) in CALLABLE_PACKAGE_SHIMS:
            continue
        elif RANK[target] >= RANK[source]:
            bad.append(f"{where}: {source} imports {target}")
    assert not bad, "imports against lsys -> sim -> compare -> simplify -> scene/export -> plantlod -> cli:\n" \
        + "\n".join(bad)


def test_no_cycles_between_packages():
    graph: dict[str, set[str]] = {}
    for source, target, where in edges():
        if (source, target, where.split(":")[0]) in CALLABLE_PACKAGE_SHIMS:
            continue
        graph.setdefault(source, set()).add(target)

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        for nxt in graph.get(start, ()):
            if nxt == goal or (nxt not in seen and reaches(nxt, goal, seen | {nxt})):
                return True
        return False

    cycles = sorted(p for p in graph if reaches(p, p, {p}))
    assert not cycles, f"packages on an import cycle: {cycles}"


def test_the_check_sees_a_wrong_edge(tmp_path, monkeypatch):
    """The test can fail: a module of lsys importing sim is reported."""
    folder = tmp_path / "lsys"
    folder.mkdir()
    (folder / "bad.py").write_text("from plantlod.sim.run import simulate\n")
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    monkeypatch.setattr(__import__(__name__), "FOLDERS", {"lsys": "lsys"})
    assert ("lsys", "sim") in {(a, b) for a, b, _ in edges()}
