#!/usr/bin/env python3
"""The names C++ and GLSL share, checked in `make test` (docs/architecture.md): every uniform the
C++ side sets by name (gl::uniformLocation(program, "name") or a file's own uniform(program,
"name") helper) is declared by a shader that file loads (its #includes followed), and every
plain uniform a shader declares (not a sampler or image, which bind by layout(binding)) is set by
a C++ file that loads it. A rename on one side only fails here, at test time, instead of at run
time on the path that uses it. Struct uniforms count by member ("hemisphere.normal").

Usage: check_gpu_names.py [ROOT]   (ROOT defaults to the checkout this script is in). Exit 0 when
every name matches, 1 with one line per mismatch.
"""
import os
import re
import sys

SHADER_LITERAL = re.compile(r'"((?:common|radiosity|raytrace|subsurface)/\w+\.(?:comp|vert|frag))"')
SET_LITERAL = re.compile(r'\b(?:uniformLocation|uniform)\(\s*[^,()]+(?:\([^()]*\))?\s*,\s*"([\w.\[\]]+)"')
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
STRUCT = re.compile(r'\bstruct\s+(\w+)\s*\{([^}]*)\}', re.S)
MEMBER = re.compile(r'^\s*(?:highp\s+|mediump\s+|lowp\s+)?(\w+)\s+(\w+)\s*(\[[^\]]*\])?\s*;', re.M)
# A plain uniform at file scope: `uniform TYPE NAME;` or with layout(location = N).
UNIFORM = re.compile(r'^\s*(?:layout\s*\([^)]*\)\s*)?uniform\s+([\w\s,\[\]]+);', re.M)
QUALIFIERS = {"readonly", "writeonly", "coherent", "volatile", "restrict", "highp", "mediump",
              "lowp", "flat", "smooth"}
# Uniform members the shaders fill in themselves, each with the reason.
UNSET_BY_DESIGN = {
    ("radiosity/progressive_depth.vert", "hemisphere.origin"): "each batch point's position",
    ("radiosity/progressive_receive.frag", "hemisphere.origin"): "each receiver point's position",
}
OPAQUE = re.compile(r'^(?:[iu]?sampler|[iu]?image|atomic_uint)')


def strip_comments(text):
    text = re.sub(r'/\*.*?\*/', lambda m: re.sub(r'[^\n]', ' ', m.group(0)), text, flags=re.S)
    return re.sub(r'//[^\n]*', '', text)


def shader_text(shaders, path, seen=None):
    seen = set() if seen is None else seen
    if path in seen:
        return ""
    seen.add(path)
    with open(os.path.join(shaders, path), encoding="utf-8") as f:
        text = strip_comments(f.read())
    out = [text]
    for inc in INCLUDE.findall(text):
        out.append(shader_text(shaders, inc, seen))
    return "\n".join(out)


def declared_uniforms(text):
    structs = {name: MEMBER.findall(body) for name, body in STRUCT.findall(text)}
    names = set()
    for declaration in UNIFORM.findall(text):
        words = declaration.split()
        while words and words[0] in QUALIFIERS:
            words.pop(0)
        if len(words) < 2:
            continue
        type_name, declarators = words[0], " ".join(words[1:])
        if OPAQUE.match(type_name):
            continue
        for declarator in declarators.split(","):
            name = declarator.split("[")[0].strip()
            if type_name in structs:
                names.update(f"{name}.{member}" for _, member, _ in structs[type_name])
            else:
                names.add(name)
    return names


def main(argv):
    root = argv[1] if len(argv) > 1 else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    src = os.path.join(root, "src", "penumbra")
    shaders = os.path.join(root, "shaders")
    errors = []
    set_by_shader = {}  # shader -> names its loaders set
    declared_by_shader = {}
    for folder, _, files in os.walk(src):
        for name in sorted(files):
            if not name.endswith(".cpp"):
                continue
            path = os.path.join(folder, name)
            with open(path, encoding="utf-8") as f:
                code = strip_comments(f.read())
            loaded = sorted(set(SHADER_LITERAL.findall(code)))
            used = {u.split("[")[0] for u in SET_LITERAL.findall(code)}
            if not loaded:
                if used:
                    errors.append(f"{os.path.relpath(path, root)}: sets uniforms "
                                  f"({', '.join(sorted(used))}) but names no shader it loads")
                continue
            declared = set()
            for shader in loaded:
                if shader not in declared_by_shader:
                    declared_by_shader[shader] = declared_uniforms(shader_text(shaders, shader))
                declared |= declared_by_shader[shader]
                set_by_shader.setdefault(shader, set()).update(used)
            for u in sorted(used - declared):
                errors.append(f"{os.path.relpath(path, root)}: sets uniform '{u}', which none of "
                              f"its shaders declares ({', '.join(loaded)})")
    for shader, declared in sorted(declared_by_shader.items()):
        for u in sorted(declared - set_by_shader.get(shader, set())):
            if (shader, u) in UNSET_BY_DESIGN:
                continue
            errors.append(f"shaders/{shader}: declares uniform '{u}', which no C++ file that "
                          "loads it sets")
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        print(f"check_gpu_names: {len(errors)} mismatch(es)", file=sys.stderr)
        return 1
    total = sum(len(d) for d in declared_by_shader.values())
    print(f"check_gpu_names: {total} uniforms of {len(declared_by_shader)} shaders, each set by "
          "name from C++ and declared where it is set")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
