"""The project's module structure: no import circles, the library below the benchmark and
the generator, the benchmark's product below its studies, files opened only in
``viewadapt.io``, no module importing another's private names.

Every import counts, at module level or inside a function (a lazy import still ties the
two modules together). ``from package import name`` is an edge to ``package.name`` when
that is a module, else to ``package`` itself.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("viewadapt", "benchmark", "generator")
#: calls that read, write or remove a file (method or function names), and numpy's
FILE_CALLS = {"open", "read_text", "write_text", "read_bytes", "write_bytes", "imread",
              "imwrite", "VideoCapture", "VideoWriter", "to_csv", "to_parquet", "read_csv",
              "read_parquet", "savefig", "mkdir", "unlink", "rmdir", "rmtree", "savez",
              "savez_compressed", "loadtxt", "savetxt"}
NUMPY_FILE_CALLS = {"load", "save"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def project_modules() -> dict:
    """Module name -> path of every project module."""
    return {_module_name(p): p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")
            if ".venv" not in p.parts}


def imports_of(name: str, path: Path, modules) -> list:
    """(imported module, names imported from it, line) of every import in the module."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, [], node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            for a in node.names:
                sub = f"{mod}.{a.name}"
                if sub in modules:
                    out.append((sub, [], node.lineno))
                else:
                    out.append((mod, [a.name], node.lineno))
    return out


def import_graph():
    modules = project_modules()
    graph = {m: set() for m in modules}
    names = []
    for m, p in modules.items():
        for target, imported, line in imports_of(m, p, modules):
            if target in modules and target != m:
                graph[m].add(target)
                names += [(m, target, n, line) for n in imported]
    return graph, names


def strongly_connected(graph) -> list:
    """Tarjan's algorithm: the components with more than one module."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_checker_finds_a_circle_and_resolves_relative_imports(tmp_path):
    assert strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [
        ["a", "b", "c"]]
    assert strongly_connected({"a": {"b"}, "b": set()}) == []
    f = tmp_path / "m.py"
    f.write_text("from . import x\nfrom ..y import z\ndef f():\n    import q.r\n")
    got = imports_of("pkg.sub.m", f, {"pkg.sub.x"})
    assert got == [("pkg.sub.x", [], 1), ("pkg.y", ["z"], 2), ("q.r", [], 4)]


def test_no_import_circles():
    graph, _ = import_graph()
    circles = strongly_connected(graph)
    assert not circles, "import circles: " + "; ".join(" <-> ".join(c) for c in circles)


@pytest.mark.parametrize("above", ["benchmark", "generator"])
def test_the_library_never_imports_the_benchmark_or_the_generator(above):
    graph, _ = import_graph()
    bad = sorted((m, t) for m, ts in graph.items() for t in ts
                 if m.split(".")[0] == "viewadapt" and t.split(".")[0] == above)
    assert not bad, f"viewadapt modules importing {above}: {bad}"


def test_the_benchmark_never_imports_its_studies():
    graph, _ = import_graph()
    studies = "benchmark.studies"
    bad = sorted((m, t) for m, ts in graph.items() for t in ts
                 if m.startswith("benchmark") and not m.startswith(studies)
                 and t.startswith(studies + "."))
    assert not bad, f"benchmark modules importing a study: {bad}"


@pytest.mark.parametrize("below, above", [
    ("viewadapt.detect", "viewadapt.commands"), ("viewadapt.camera", "viewadapt.commands"),
    ("viewadapt.io", "viewadapt.commands"), ("viewadapt.commands", "viewadapt.cli"),
    ("viewadapt.camera", "viewadapt.detect")])
def test_the_library_layers(below, above):
    """Algorithms below the files (io) and the commands; the commands below the CLI."""
    graph, _ = import_graph()
    bad = sorted((m, t) for m, ts in graph.items() for t in ts
                 if (m == below or m.startswith(below + "."))
                 and (t == above or t.startswith(above + ".")))
    assert not bad, f"{below} importing {above}: {bad}"


def file_calls(path: Path) -> list:
    """(line, call) of every call in the module that reads, writes or removes a file."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        name = f.id if isinstance(f, ast.Name) else getattr(f, "attr", None)
        owner = f.value.id if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) \
            else None
        if name in FILE_CALLS or (name in NUMPY_FILE_CALLS and owner in ("np", "numpy")):
            out.append((node.lineno, name))
    return out


def test_the_file_check_finds_file_calls(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("import numpy as np\nnp.load(p)\nopen(p)\nx.write_text('a')\n"
                 "d.load(p)\nx.exists()\n")
    assert file_calls(f) == [(2, "load"), (3, "open"), (4, "write_text")]


def test_only_viewadapt_io_opens_files():
    bad = [f"{m}:{line} {call}" for m, p in project_modules().items()
           if m.split(".")[0] == "viewadapt" and not m.startswith("viewadapt.io")
           for line, call in file_calls(p)]
    assert not bad, "file access outside viewadapt.io:\n" + "\n".join(bad)


def test_no_module_imports_another_modules_private_names():
    _, names = import_graph()
    bad = [f"{m}:{line} imports {n} from {t}" for m, t, n, line in names
           if n.startswith("_") and not n.startswith("__")]
    assert not bad, "\n".join(bad)


#: a module (or test file) past this many lines is two modules
MAX_LINES = 600


def test_no_file_is_over_600_lines():
    files = [p for pkg in PACKAGES + ("tests",) for p in (ROOT / pkg).rglob("*.py")
             if ".venv" not in p.parts]
    long = sorted(f"{p.relative_to(ROOT)}: {n}" for p in files
                  if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES)
    assert not long, "files over 600 lines:\n" + "\n".join(long)
