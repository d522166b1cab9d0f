#!/usr/bin/env python3
"""The library's structure, checked in `make test` (docs/architecture.md):

  modules   src/penumbra/<module>/ includes only the modules its row of ALLOWED names (core is
            allowed everywhere), so the modules form a DAG;
  functions no function in src/ is longer than MAX_FUNCTION_LINES lines, counted from the line of
            its name to its closing brace;
  app       src/penumbra/app/ (the CLI) stays under MAX_APP_LINES lines;
  api       src/penumbra/api/ calls no command line (runCommandLine) and includes nothing of app/.

Usage: check_structure.py [--list | --dot] [SRC]   (SRC defaults to the src/ beside this script's
folder). --list prints every function over the limit, longest first, and the module graph;
--dot prints the module graph the sources have, for graphviz (docs/images/modules.png:
check_structure.py --dot | dot -Tpng -Gdpi=110 -o docs/images/modules.png).
Exit status 0 when everything holds, 1 with one line per violation otherwise.
"""
import os
import re
import sys

# The module table of docs/architecture.md: each module may include the ones listed (and core).
# It is a DAG by construction: every module lists only modules above it.
ALLOWED = {
    "core": set(),
    "kernels": set(),
    "accel": {"kernels"},
    "gpu": set(),
    "cluster": set(),
    "scene": {"kernels"},
    "io": {"scene", "kernels", "geometry"},
    "geometry": {"scene", "kernels"},
    "raytrace": {"scene", "kernels", "accel", "gpu", "cluster"},
    "radiosity": {"raytrace", "geometry", "scene", "kernels", "accel", "gpu", "cluster"},
    "subsurface": {"radiosity", "raytrace", "geometry", "scene", "kernels", "accel", "gpu",
                   "cluster"},
    "render": {"radiosity", "subsurface", "raytrace", "geometry", "scene", "io", "kernels",
               "accel", "gpu", "cluster"},
}
# The run logic's modules sit above every engine module (methods/ is the registry; interactive/ its
# live sessions; api/ the public API over both; app/ the CLI).
ENGINE = set(ALLOWED)
ALLOWED["methods"] = ENGINE
ALLOWED["interactive"] = ENGINE | {"methods"}
ALLOWED["api"] = ENGINE | {"methods", "interactive"}
ALLOWED["app"] = ENGINE | {"methods", "interactive", "api"}

MAX_FUNCTION_LINES = 120
MAX_APP_LINES = 2000

# What the library still has to bring under the limits, each at its size today: a pending
# function may shrink or go, not grow, and no other function may pass the limit; app/ may not
# grow. Lower these as the run logic moves into the methods; the check is whole when they are gone.
PENDING_FUNCTIONS = {}
PENDING_APP_LINES = 0  # app/ is under MAX_APP_LINES
PENDING_API_COMMAND_LINE = False
PENDING_MODULE_EDGES = set()

INCLUDE = re.compile(r'^\s*#\s*include\s+"penumbra/([A-Za-z_]+)/')
CONTROL = {"if", "for", "while", "switch", "catch", "do", "else", "try", "return", "sizeof",
           "alignof", "decltype", "static_assert", "requires"}


def source_files(root):
    for folder, _, files in os.walk(root):
        for name in sorted(files):
            if name.endswith((".cpp", ".h")):
                yield os.path.join(folder, name)


def module_of(path, penumbra_root):
    rel = os.path.relpath(path, penumbra_root)
    return rel.split(os.sep)[0] if os.sep in rel else None


def check_modules(penumbra_root, errors, graph, pending):
    for path in source_files(penumbra_root):
        module = module_of(path, penumbra_root)
        if module is None:
            continue
        if module not in ALLOWED:
            errors.append(f"{path}: module '{module}' is not in the module table "
                          "(scripts/check_structure.py, docs/architecture.md)")
            continue
        with open(path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target = m.group(1)
                if target in (module, "core"):
                    continue
                graph.setdefault(module, set()).add(target)
                if target not in ALLOWED[module] and (module, target) in PENDING_MODULE_EDGES:
                    pending.append(f"{path}:{number}: {module} includes {target} (pending)")
                elif target not in ALLOWED[module]:
                    errors.append(f"{path}:{number}: module {module} may not include {target} "
                                  f"(allowed: core, {', '.join(sorted(ALLOWED[module])) or '-'})")


def strip_code(text):
    """The text with comments, string and character literals blanked (newlines kept)."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not text[i - 1].isalnum()):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(" " * (j - i))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def function_name(header):
    """The name of the function whose definition `header` (the code before its `{`) ends, or None
    when the brace opens something else (a class, namespace, initialiser, control block)."""
    h = re.sub(r"\s+", " ", header).strip()
    if not h or h.endswith(("=", ",", "(", "return")):
        return None
    if re.search(r"\b(class|struct|union|enum|namespace)\b[^()]*$", h):
        return None
    # A constructor's member initialisers: cut them off at the ") :" that starts them.
    m = re.search(r"\)\s*(?:const\s*)?(?:noexcept\s*)?:(?!:)", h)
    if m:
        h = h[: m.start() + 1]
    # Trailing qualifiers and a trailing return type.
    h = re.sub(r"\s*->\s*[^()]*$", "", h)
    h = re.sub(r"(\s*\b(const|noexcept|override|final|mutable|volatile)\b|\s*&&?)+\s*$", "", h)
    if not h.endswith(")"):
        return None
    # Find the parameter list's opening parenthesis.
    depth = 0
    for k in range(len(h) - 1, -1, -1):
        if h[k] == ")":
            depth += 1
        elif h[k] == "(":
            depth -= 1
            if depth == 0:
                break
    else:
        return None
    m = re.search(r"(~?[A-Za-z_][\w:~]*(?:<[^<>]*>)?|operator\s*[^\s(]+)\s*$", h[:k])
    if not m:
        return None
    name = m.group(1)
    if name.split("::")[-1] in CONTROL or name.endswith("]"):
        return None
    before = h[: m.start()].rstrip()
    if before.endswith(("=", "(", ",", "return", "[", "&&", "||", "!", "?", ":")) and \
            not before.endswith("::"):
        return None
    return name


def long_functions(path):
    with open(path, encoding="utf-8") as f:
        code = strip_code(f.read())
    found = []
    # A stack of open braces: (is_function_body, name, start_line). Only braces at a scope that
    # can hold a function definition (file, namespace, class) can open a function body.
    stack = []
    header_start = 0
    line = 1
    i = 0
    n = len(code)
    while i < n:
        c = code[i]
        if c == "\n":
            line += 1
        elif c in ";}" or (c == "{"):
            in_function = any(entry[0] for entry in stack)
            if c == "{":
                name = None
                if not in_function:
                    header = code[header_start:i]
                    # Preprocessor lines are not part of the header.
                    header = "\n".join(l for l in header.split("\n")
                                       if not l.lstrip().startswith("#"))
                    name = function_name(header)
                start = line - code[header_start:i].count("\n") if name else line
                if name:
                    # The definition starts at the line holding the function's name.
                    text = code[header_start:i]
                    k = text.find(name.split("::")[-1].split("<")[0])
                    start = line - text[k:].count("\n") if k >= 0 else start
                stack.append((name is not None, name, start))
            elif c == "}" and stack:
                is_function, name, start = stack.pop()
                if is_function:
                    length = line - start + 1
                    if length > MAX_FUNCTION_LINES:
                        found.append((length, name, start))
            header_start = i + 1
        i += 1
    return found


def find_cycle(graph):
    """A cycle of the module graph as a list of modules (first == last), or None."""
    state = {}

    def visit(m, path):
        state[m] = "open"
        for n in sorted(graph.get(m, ())):
            if state.get(n) == "open":
                return path[path.index(n):] + [n] if n in path else [m, n, m]
            if n not in state:
                found = visit(n, path + [n])
                if found:
                    return found
        state[m] = "done"
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m, [m])
            if found:
                return found
    return None


def module_graph_dot(graph):
    """The modules and their includes, without the edges another path already implies."""
    def reaches(a, b, skip):
        stack, seen = [a], set()
        while stack:
            m = stack.pop()
            for n in graph.get(m, ()):
                if (m, n) == skip or n in seen:
                    continue
                if n == b:
                    return True
                seen.add(n)
                stack.append(n)
        return False
    layers = [["app"], ["api"], ["interactive"], ["methods"], ["render"], ["subsurface"],
              ["radiosity"], ["raytrace", "io"], ["geometry", "accel", "gpu", "cluster"],
              ["scene"], ["kernels"]]
    lines = ["digraph modules {", '  rankdir=TB; node [shape=box, style="rounded,filled", '
             'fillcolor="#eef3fb", fontname="Helvetica"]; edge [color="#5577aa"];',
             '  label="src/penumbra: each module includes only those below it '
             '(core, under all, not drawn)"; labelloc=b; fontname="Helvetica";']
    for layer in layers:
        lines.append("  { rank=same; " + " ".join(layer) + "; }")
    for a in sorted(graph):
        for b in sorted(graph[a]):
            if not reaches(a, b, (a, b)):
                lines.append(f"  {a} -> {b};")
    lines.append("}")
    return "\n".join(lines)


def main(argv):
    listing = "--list" in argv
    dot = "--dot" in argv
    args = [a for a in argv[1:] if a not in ("--list", "--dot")]
    src = args[0] if args else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                                            "src")
    src = os.path.normpath(src)
    penumbra_root = os.path.join(src, "penumbra")
    errors = []
    graph = {}
    pending = []
    check_modules(penumbra_root, errors, graph, pending)

    # The graph the sources have, pending edges included, must be acyclic.
    cycle = find_cycle(graph)
    if cycle:
        errors.append(f"{penumbra_root}: modules include each other in a cycle: "
                      f"{' -> '.join(cycle)}")

    longest = []
    for path in source_files(src):
        for length, name, start in long_functions(path):
            longest.append((length, f"{os.path.relpath(path, os.path.dirname(src))}:{start}",
                            name))
    longest.sort(reverse=True)
    for length, place, name in longest:
        key = (place.split(":")[0], name)
        ceiling = PENDING_FUNCTIONS.get(key)
        if ceiling is not None and length <= ceiling:
            pending.append(f"{place}: {name} is {length} lines (pending, at most {ceiling})")
            continue
        errors.append(f"{place}: {name} is {length} lines (at most "
                      f"{ceiling if ceiling is not None else MAX_FUNCTION_LINES}: split it into "
                      "named steps)")

    app = os.path.join(penumbra_root, "app")
    app_lines = 0
    for path in source_files(app):
        with open(path, encoding="utf-8") as f:
            app_lines += sum(1 for _ in f)
    if app_lines > MAX_APP_LINES and PENDING_APP_LINES is not None and \
            app_lines <= PENDING_APP_LINES:
        pending.append(f"{app}: {app_lines} lines (pending, at most {PENDING_APP_LINES})")
    elif app_lines > MAX_APP_LINES:
        errors.append(f"{app}: {app_lines} lines (at most {MAX_APP_LINES}: run logic belongs in "
                      "the methods' modules)")

    api = os.path.join(penumbra_root, "api")
    for path in source_files(api):
        with open(path, encoding="utf-8") as f:
            for number, text in enumerate(f, 1):
                if "runCommandLine" in strip_code(text) and PENDING_API_COMMAND_LINE:
                    pending.append(f"{path}:{number}: the API runs the command line (pending)")
                elif "runCommandLine" in strip_code(text):
                    errors.append(f"{path}:{number}: the API runs no command line "
                                  "(runCommandLine): it calls the methods")

    if dot:
        print(module_graph_dot(graph))
        return 0
    if listing:
        for module in sorted(graph):
            print(f"{module} -> {', '.join(sorted(graph[module]))}")
        print(f"app/: {app_lines} lines")
        for length, place, name in longest:
            print(f"{length:5d}  {place}  {name}")
    for p in pending:
        print(p)
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check_structure: {len(errors)} violation(s)", file=sys.stderr)
        return 1
    left = f", except {len(pending)} pending item(s) listed above" if pending else ""
    print(f"check_structure: modules form a DAG; no function over {MAX_FUNCTION_LINES} lines"
          f"{left}; app/ {app_lines} lines; api/ calls no command line")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
