#!/usr/bin/env python3
"""doc_links.py — checks that every relative link in README.md and docs/*.md names a file
that exists and, with a #fragment, a heading (or <a id>) of that file, using GitHub's
anchor rule (lower case, punctuation other than '-' and '_' dropped, spaces to '-',
repeats numbered -1, -2, ...). docs/journal/ is history kept unedited and is not checked.
Exit status 0 when every link resolves, 1 with one line per broken link."""
import os
import re
import sys

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)|<img[^>]*\ssrc=\"([^\"]+)\"")
FENCE = re.compile(r"^(```|~~~)")


def slug(title):
    """GitHub's anchor of a heading: inline code and links keep their text."""
    t = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", title.strip())
    t = t.lower()
    t = re.sub(r"[^\w\- ]", "", t)
    return t.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen = {}
        found = set()
        in_fence = False
        with open(path, encoding="utf-8") as f:
            for line in f:
                if FENCE.match(line):
                    in_fence = not in_fence
                    continue
                if in_fence:
                    continue
                for a in re.findall(r"<a id=\"([^\"]+)\"", line):
                    found.add(a)
                m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
                if m:
                    s = slug(m.group(1))
                    n = seen.get(s, 0)
                    seen[s] = n + 1
                    found.add(s if n == 0 else f"{s}-{n}")
        cache[path] = found
    return cache[path]


def pages():
    yield os.path.join(ROOT, "README.md")
    d = os.path.join(ROOT, "docs")
    for name in sorted(os.listdir(d)):
        if name.endswith(".md"):
            yield os.path.join(d, name)


def main():
    bad = []
    count = 0
    for page in pages():
        in_fence = False
        with open(page, encoding="utf-8") as f:
            for no, line in enumerate(f, 1):
                if FENCE.match(line):
                    in_fence = not in_fence
                    continue
                if in_fence:
                    continue
                line = re.sub(r"`[^`]*`", "", line)
                for m in LINK.finditer(line):
                    target = m.group(1) or m.group(2)
                    if re.match(r"^[a-z]+:", target):
                        continue  # http:, https:, mailto:
                    count += 1
                    path, _, frag = target.partition("#")
                    full = os.path.normpath(os.path.join(os.path.dirname(page), path)) if path else page
                    where = f"{os.path.relpath(page, ROOT)}:{no}: {target}"
                    if not os.path.exists(full):
                        bad.append(f"{where}: no file {os.path.relpath(full, ROOT)}")
                    elif frag and full.endswith(".md") and frag not in anchors(full):
                        bad.append(f"{where}: no heading with anchor #{frag}")
    for b in bad:
        print(b)
    print(f"doc_links: {count} links, {len(bad)} broken")
    return 1 if bad or count == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
