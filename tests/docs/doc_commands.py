#!/usr/bin/env python3
"""doc_commands.py SOURCE TESSERA [--list] — runs the `tessera` commands a user would copy
from README.md and docs/*.md (docs/journal/ is history and is left out), small, and fails
when one fails.

Which commands: the lines of fenced ```sh blocks that call build/tessera (render, bake,
devices, --help), after an optional environment prefix (POCL_DEVICES=... and the like) and
an optional `/usr/bin/time -v` or `/usr/bin/time -f "..."`. Left out: a block right after
the marker line `<!-- doc-test: skip (why) -->`; lines with shell variables, pipes, `;`,
`&&` or redirections; lines whose arguments are placeholders (a word in capitals such as
OUT, BIN, DIR, KIND). Each render gets `--res 32x18 --spp 1 --quiet` and each bake
`--res 32x18 --rays 4 --lod 1 --quiet` appended (later options win), so that the whole set
runs in well under a minute on 2 cores. Outputs (`-o`, `--stats`, any `out/...` path) go to
a temporary directory; what one command writes there a later one may read (a bake's file
for `--occlusion`). Exit status 0, 1 with each failing command and its stderr, and 1 when
no command was found (the extraction itself broke); 77 without an OpenCL device."""
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time

SKIP = re.compile(r"<!--\s*doc-test:\s*skip\b")
TIME = re.compile(r"^/usr/bin/time\s+(-v|-f\s+(\"[^\"]*\"|'[^']*'|\S+))\s+")
PLACEHOLDER = re.compile(r"^[A-Z][A-Z_]*[0-9]?$")
SMALL = {"render": ["--res", "32x18", "--spp", "1", "--quiet"],
         "bake": ["--res", "32x18", "--rays", "4", "--lod", "1", "--quiet"]}


def pages(source):
    yield "README.md"
    for name in sorted(os.listdir(os.path.join(source, "docs"))):
        if name.endswith(".md"):
            yield os.path.join("docs", name)


def sh_blocks(text):
    """(first line number, lines) of each ```sh block not marked to be skipped."""
    lines = text.split("\n")
    i, prev = 0, ""
    while i < len(lines):
        if re.match(r"^\s*```(sh|bash|shell)\s*$", lines[i]):
            start, body = i + 1, []
            i += 1
            while i < len(lines) and not re.match(r"^\s*```\s*$", lines[i]):
                body.append(lines[i])
                i += 1
            if not SKIP.search(prev):
                yield start + 1, body
        if lines[i - 1 if i >= len(lines) else i].strip():
            prev = lines[i] if i < len(lines) else ""
        i += 1


def joined(body):
    """Lines with their backslash continuations joined, comments cut."""
    out, cur, first = [], "", None
    for n, line in enumerate(body):
        if first is None:
            first = n
        if line.rstrip().endswith("\\"):
            cur += line.rstrip()[:-1] + " "
            continue
        cur += line
        out.append((first, cur))
        cur, first = "", None
    return out


def command(line):
    """The argv (and environment additions) of a runnable tessera line, else None."""
    try:
        words = shlex.split(line, comments=True)
    except ValueError:
        return None
    if not words:
        return None
    env = {}
    while words and re.match(r"^[A-Z_][A-Z0-9_]*=", words[0]):
        k, _, v = words.pop(0).partition("=")
        env[k] = v
    text = shlex.join(words)
    text = TIME.sub("", text)
    words = shlex.split(text)
    if not words or words[0] != "build/tessera":
        return None
    if any(c in line for c in ("$", "|", ";", "&&", ">", "<", "`")):
        return None
    if any(PLACEHOLDER.match(w) or "..." in w for w in words[1:]):
        return None
    return env, words


def main():
    source, tessera = sys.argv[1], sys.argv[2]
    listing = "--list" in sys.argv[3:]
    cmds = []
    for page in pages(source):
        text = open(os.path.join(source, page), encoding="utf-8").read()
        for start, body in sh_blocks(text):
            for off, line in joined(body):
                c = command(line)
                if c:
                    cmds.append((f"{page}:{start + off}", c[0], c[1]))
    if not listing and subprocess.run([tessera, "devices"], capture_output=True).returncode != 0:
        print("doc_commands: no OpenCL device (skipped)")
        return 77
    tmp = tempfile.mkdtemp(prefix="doc_commands.")
    failed, t0 = [], time.time()
    for where, env, words in cmds:
        argv = [tessera]
        out_next = False
        for w in words[1:]:
            if w.startswith("out/"):
                w = os.path.join(tmp, w[4:])
            elif "/" not in w and (out_next or re.search(r"\.(exr|png|json|jsn)$", w)):
                w = os.path.join(tmp, w)
            out_next = w in ("-o", "--output", "--stats")
            argv.append(w)
        if len(argv) > 1 and argv[1] in SMALL:
            argv += SMALL[argv[1]]
        if listing:
            print(where, " ".join(f"{k}={v}" for k, v in env.items()), shlex.join(argv))
            continue
        for a in argv:
            if a.startswith(tmp):
                os.makedirs(os.path.dirname(a), exist_ok=True)
        start = time.time()
        r = subprocess.run(argv, cwd=source, env={**os.environ, **env}, capture_output=True,
                           text=True, timeout=120)
        secs = time.time() - start
        print(f"{'ok  ' if r.returncode == 0 else 'FAIL'} {secs:5.1f} s  {where}: "
              f"{shlex.join(words)}", flush=True)
        if r.returncode != 0:
            failed.append(f"{where}: {shlex.join(argv)} exited {r.returncode}\n{r.stderr[-2000:]}")
    print("\n".join(failed))
    print(f"doc_commands: {len(cmds)} commands, {len(failed)} failed, {time.time() - t0:.0f} s")
    return 1 if failed or not cmds else 0


if __name__ == "__main__":
    sys.exit(main())
