#!/usr/bin/env python3
"""check_layers.py -- host/ includes only point down the layers (docs/building.md "Layers").

It also checks that docs/building.md's source-layout table names every .c/.cpp file of each
host/ folder in that folder's row.

Every host source names what it includes by layer: #include "pipeline/pipeline.h". A file in
host/<layer>/ may include its own layer, the layers listed for it below, and the shared
kernel headers (lib/...); anything else, and any quoted include without a layer, is an
error naming the file, the line and the rule. System headers (<...>) are not checked.

  tools/check_layers.py [--root DIR]   check DIR/host (default: the repository)
  tools/check_layers.py --self-test    plant an upward include in a copy of host/ and
                                       check that it is caught (ctest check_layers_planted)
Exit status: 0 clean, 1 a violation, 2 usage.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

# What each layer may include besides itself. app -> pipeline -> device, scene, image, base;
# scene reads textures through image; ref (the plain-C references of the kernels, linked by
# tests and tools) sits on scene and base and never reaches the pipeline it checks.
ALLOWED = {
    "app": {"pipeline", "device", "scene", "image", "base"},
    "pipeline": {"device", "scene", "image", "base"},
    "device": {"base"},
    "scene": {"image", "base"},
    "image": {"base"},
    "base": set(),
    "ref": {"scene", "base"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"')


def layer_of(rel):
    """The layer of a path relative to host/ (scene/rib/x.c is in layer scene)."""
    return rel.split("/", 1)[0] if "/" in rel else None


def check(root):
    host = os.path.join(root, "host")
    problems = []
    for dirpath, _, names in sorted(os.walk(host)):
        for name in sorted(names):
            if not name.endswith((".c", ".h", ".cpp")):
                continue
            path = os.path.join(dirpath, name)
            rel = os.path.relpath(path, host)
            mine = layer_of(rel)
            if mine not in ALLOWED:
                problems.append(f"host/{rel}: not inside a layer folder ({', '.join(sorted(ALLOWED))})")
                continue
            with open(path, encoding="utf-8", errors="replace") as f:
                for number, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    target = m.group(1)
                    if target.startswith("lib/"):
                        continue  # kernels/lib: shared by host and kernels, below every layer
                    theirs = layer_of(target)
                    if theirs not in ALLOWED:
                        problems.append(f"host/{rel}:{number}: #include \"{target}\" names no layer "
                                        f"(write it as \"<layer>/...\")")
                    elif theirs != mine and theirs not in ALLOWED[mine]:
                        may = ", ".join(sorted(ALLOWED[mine])) or "nothing else"
                        problems.append(f"host/{rel}:{number}: #include \"{target}\": layer {mine} "
                                        f"may include {may}, not {theirs}")
    return problems


def check_docs(root):
    """Every .c/.cpp file of host/<folder>/ is named in docs/building.md's row for that folder."""
    path = os.path.join(root, "docs", "building.md")
    if not os.path.exists(path):
        return []
    rows = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"\| `host/([a-z/]+)/` \|(.*)", line)
            if m:
                rows[m.group(1)] = m.group(2)
    problems = []
    host = os.path.join(root, "host")
    for dirpath, _, names in sorted(os.walk(host)):
        folder = os.path.relpath(dirpath, host)
        for name in sorted(n for n in names if n.endswith((".c", ".cpp"))):
            if folder not in rows:
                problems.append(f"docs/building.md: no layout row for host/{folder}/ (holds {name})")
                break
            if f"`{name}`" not in rows[folder]:
                problems.append(f"docs/building.md: the host/{folder}/ row does not name {name}")
    return problems


def self_test(root):
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copytree(os.path.join(root, "host"), os.path.join(tmp, "host"))
        if check(tmp):
            print("self-test: the real tree is not clean, fix that first", file=sys.stderr)
            return 1
        victim = os.path.join(tmp, "host", "base", "error.c")
        with open(victim, "a") as f:
            f.write('#include "pipeline/pipeline.h"\n')
        out = subprocess.run([sys.executable, __file__, "--root", tmp], capture_output=True, text=True)
        expect = "host/base/error.c:"
        if out.returncode != 1 or expect not in out.stderr or "not pipeline" not in out.stderr:
            print(f"self-test: a planted upward include was not reported (exit {out.returncode}):\n"
                  f"{out.stderr}", file=sys.stderr)
            return 1
    print("self-test: the planted include in host/base/error.c was reported")
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--root", default=os.path.join(os.path.dirname(__file__), ".."))
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    if a.self_test:
        return self_test(a.root)
    problems = check(a.root) + check_docs(a.root)
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        print(f"check_layers: {len(problems)} problem(s): includes against the layers or an out-of-date layout table", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
