"""The workspace's structure, checked: no import circle between the files of a crate,
and the general FMI master free of every estimator and vehicle-model crate.

A file's imports are the `crate::a::b` paths it names (in `use` items or inline) and its `mod`
children; `crate::a::b::Item` counts as an edge to the file of module `a::b` (or of `a` when `b`
is an item). `super::` is resolved against the file's own module path. A module that only
declares its children (`mod.rs`/`lib.rs` holding `pub mod x;` lines) is an edge to each child,
and a child that names its parent's items would make a circle through the parent: such
re-exports and shared items are counted, which is the point: a circle means two files that
cannot be understood, tested or moved one without the other. Test modules (`#[cfg(test)] mod
tests { ... }` bodies) are skipped: they may use anything of their own file."""

import json
import pathlib
import re
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[2]
PATH_RE = re.compile(r"(?<![$\w])(?<!use )(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
MOD_RE = re.compile(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+([A-Za-z_][A-Za-z0-9_]*)\s*;", re.M)
FORBIDDEN_IN_MASTER = {"estimation", "vehicle-models", "vehicle-state-estimator",
                       "reference-vehicle"}


def cargo_metadata():
    out = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"], cwd=ROOT,
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def strip_comments_and_tests(text):
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    # Drop `#[cfg(test)] mod name { ... }` bodies by brace matching.
    out, i = [], 0
    for match in re.finditer(r"#\[cfg\(test\)\]\s*(?:pub\s+)?mod\s+\w+\s*\{", text):
        if match.start() < i:
            continue
        out.append(text[i:match.start()])
        depth, j = 1, match.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def crate_modules(src_root, root_file):
    """{module path tuple: file} of one crate target, following `mod x;` declarations."""
    modules = {}

    def visit(path, file):
        modules[path] = file
        text = strip_comments_and_tests(file.read_text())
        for name in MOD_RE.findall(text):
            base = file.parent if file.name in ("lib.rs", "main.rs", "mod.rs") else \
                file.parent / file.stem
            for candidate in (base / f"{name}.rs", base / name / "mod.rs"):
                if candidate.is_file():
                    visit(path + (name,), candidate)
                    break

    visit((), root_file)
    return modules


def resolve(modules, current, kind, segments):
    path = () if kind == "crate" else current[:-1]
    rest = list(segments)
    while rest and rest[0] == "super":
        path = path[:-1]
        rest.pop(0)
    best = path if path in modules else None
    for segment in rest:
        path = path + (segment,)
        if path in modules:
            best = path
        else:
            break
    return best


REEXPORT_RE = re.compile(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);")


def use_paths(clause):
    """The full paths of one `use` clause: `a::{b, c::{d, e}}` -> a::b, a::c::d, a::c::e."""
    clause = re.sub(r"\s+", "", clause)
    if "{" not in clause:
        yield clause
        return
    head, body = clause.split("{", 1)
    body = body[:-1]
    depth, part, parts = 0, "", []
    for ch in body:
        if ch == "," and depth == 0:
            parts.append(part)
            part = ""
            continue
        depth += {"{": 1, "}": -1}.get(ch, 0)
        part += ch
    parts.append(part)
    for item in filter(None, parts):
        yield from use_paths(head + item)


def reexports(modules):
    """{(module, name): module path the name is re-exported from}, from `pub use` items."""
    found = {}
    for path, file in modules.items():
        text = strip_comments_and_tests(file.read_text())
        for clause in REEXPORT_RE.findall(text):
            for full in use_paths(clause):
                segments = full.split("::")
                name = segments[-1].split(" as ")[-1]
                if segments[0] in ("crate", "super", "self"):
                    target = resolve(modules, path, segments[0] if segments[0] != "self"
                                     else "self", segments[1:], {})
                elif (path + (segments[0],)) in modules:
                    target = resolve(modules, path, "self", segments, {})
                else:
                    continue
                if target is not None:
                    found[(path, name)] = target
    return found


def resolve(modules, current, kind, segments, exported):
    """The file (module path) that a `crate::`, `super::` or `self::` path points into: the
    deepest module it names, followed through `pub use` re-exports of the item it names."""
    path = {"crate": (), "super": current[:-1], "self": current}[kind]
    rest = [s for s in segments if s]
    while rest and rest[0] == "super":
        path = path[:-1]
        rest.pop(0)
    best, seen = (path if path in modules else None), set()
    for segment in rest:
        if path + (segment,) in modules:
            path = path + (segment,)
            best = path
            continue
        while (path, segment) in exported and (path, segment) not in seen:
            seen.add((path, segment))
            best = exported[(path, segment)]
            path = best
        break
    return best


def import_graph(modules):
    """Edges from each file to the files whose items it uses (not to the children it merely
    declares with `mod`: containment is not a dependency)."""
    exported = reexports(modules)
    graph = {}
    for path, file in modules.items():
        text = strip_comments_and_tests(file.read_text())
        targets = set()
        for clause in re.findall(r"\buse\s+((?:crate|super|self)::[^;]+);", text):
            for full in use_paths(clause):
                segments = full.split(" as ")[0].split("::")
                targets.add(resolve(modules, path, segments[0], segments[1:], exported))
        for kind, rest in PATH_RE.findall(text):
            targets.add(resolve(modules, path, kind, rest.split("::"), exported))
        graph[path] = {t for t in targets if t is not None and t != path}
    return graph


def circles(graph):
    """Strongly connected components with more than one file (Tarjan)."""
    index, low, stack, on_stack, found, counter = {}, {}, [], set(), [], [0]

    def connect(node):
        index[node] = low[node] = counter[0]
        counter[0] += 1
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                connect(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(component)

    for node in graph:
        if node not in index:
            connect(node)
    return found


def library_targets():
    for package in cargo_metadata()["packages"]:
        for target in package["targets"]:
            if set(target["kind"]) & {"lib", "cdylib", "rlib"}:
                yield package["name"], pathlib.Path(target["src_path"])


def test_no_import_circle_between_the_files_of_any_crate():
    problems = []
    for name, root_file in library_targets():
        modules = crate_modules(root_file.parent, root_file)
        # The crate root declares every module and re-exports some: edges out of it are fine,
        # edges into it from a child are what would close a circle through it, so keep both.
        for component in circles(import_graph(modules)):
            files = sorted(str(modules[m].relative_to(ROOT)) for m in component)
            problems.append(f"{name}: " + " <-> ".join(files))
    assert not problems, "import circles:\n" + "\n".join(problems)


def test_the_master_crate_depends_on_no_model_or_estimator():
    packages = {p["name"]: p for p in cargo_metadata()["packages"]}
    masters = [p for p in packages.values()
               if pathlib.Path(p["manifest_path"]).parent.name == "master"]
    assert masters, "no crate under harness/master"
    for master in masters:
        names = {d["name"] for d in master["dependencies"] if d.get("kind") in (None, "normal")}
        assert not names & FORBIDDEN_IN_MASTER, (master["name"], names & FORBIDDEN_IN_MASTER)
