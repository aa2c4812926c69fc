#!/usr/bin/env python3
"""Checks the size rules of the C++ sources: no file over 400 lines, no function over 80 lines.

A function's length is counted from the line of its body's opening brace to the line of its closing brace
(lambdas and local classes count towards the function that holds them). Data tables and generated files are
exempt by name (EXEMPT below). Sources over a limit today are listed in deploy/size_limits_known.txt with
their current size: such an entry may shrink or go, never grow, and a source not listed may not pass a limit.

usage: deploy/check_sizes.py [--root DIR] [--list]
  --list   print every file and function over a limit (the format of size_limits_known.txt) and exit 0
Exit 0 when the rules hold, 1 with one line per breach otherwise.
"""
import argparse
import os
import re
import subprocess
import sys

FILE_LIMIT = 400
FUNCTION_LIMIT = 80
EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
# Generated files, by path prefix (none are in the tree: the generated sources live in the build tree).
EXEMPT = ()
# Data tables, by file and function: a configuration table (one entry per key) and a list of message schemas.
DATA_TABLES = {
    "server/core/model/src/map_server_config.cpp": {"ownTable"},
    "apps/viewer/src/foxglove_json.cpp": {"buildSchemas"},
}
SCOPE_WORDS = re.compile(r"\b(namespace|class|struct|union|enum)\b")
CONTROL_WORDS = re.compile(r"\b(if|for|while|switch|catch|do|else|try)\s*$")


def strip_code(text):
    """Blanks comments, string and character literals, keeping line breaks."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c == 'R' and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            k = text.find("(", i + 2)
            delim = ")" + text[i + 2:k] + '"'
            j = text.find(delim, k)
            j = n if j < 0 else j + len(delim)
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(c)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        elif c == "#" and (i == 0 or text[i - 1] == "\n"):
            j = i
            while True:  # a preprocessor line, with its continuations
                e = text.find("\n", j)
                if e < 0:
                    e = n
                    break
                if e > 0 and text[e - 1] == "\\":
                    j = e + 1
                    continue
                break
            out.append("\n" * text.count("\n", i, e))
            i = e
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(code):
    """Yields (name, first_line, last_line) of each outermost function body."""
    stack = []  # per open brace: kind ('scope', 'function', 'other'), line, name
    head_start = 0
    line = 1
    inside_function = 0
    for i, c in enumerate(code):
        if c == "\n":
            line += 1
        elif c == "{":
            head = code[head_start:i].strip()
            if inside_function:
                kind = "other"
            elif SCOPE_WORDS.search(head) and "(" not in head.split("{")[-1].split(":")[0]:
                kind = "scope"
            elif head.endswith(")") or re.search(r"\)\s*(const|noexcept|override|final|mutable|->[^;{}]*|:[^;{}]*)?\s*$", head) \
                    or re.search(r"\)\s*(const\s*)?(noexcept\s*)?(override\s*)?(final\s*)?$", head):
                if CONTROL_WORDS.search(head.split("(")[0]) or head.endswith("=") or head.startswith("="):
                    kind = "other"
                else:
                    kind = "function"
            elif re.search(r"\bextern\s*\"\"\s*$", head):
                kind = "scope"
            else:
                kind = "other"
            name = ""
            if kind == "function":
                m = re.search(r"([~\w:<>]+)\s*\([^()]*(\([^()]*\)[^()]*)*\)[^()]*$", head)
                name = m.group(1) if m else head[-40:]
                inside_function += 1
            stack.append((kind, line, name))
            head_start = i + 1
        elif c == "}":
            if stack:
                kind, first, name = stack.pop()
                if kind == "function":
                    inside_function -= 1
                    yield name, first, line
            head_start = i + 1
        elif c == ";":
            head_start = i + 1


def listed_files(root):
    """The files git knows (tracked, or untracked and not ignored); without git or outside a checkout, every
    file below root except build trees (build*/) and hidden or node_modules folders."""
    try:
        return subprocess.run(["git", "-C", root, "ls-files", "--cached", "--others", "--exclude-standard"],
                              capture_output=True, text=True, check=True).stdout.split()
    except (OSError, subprocess.CalledProcessError):
        files = []
        for folder, dirs, names in os.walk(root):
            dirs[:] = [d for d in dirs if not (d.startswith((".", "build")) or d == "node_modules")]
            files += [os.path.relpath(os.path.join(folder, n), root) for n in names]
        return files


def sources(root):
    for f in sorted(listed_files(root)):
        if f.endswith(EXTENSIONS) and not f.startswith(EXEMPT) and os.path.isfile(os.path.join(root, f)):
            yield f


def breaches(root):
    for f in sources(root):
        with open(os.path.join(root, f), encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        if lines > FILE_LIMIT:
            yield f"{f} file {lines}"
        for name, first, last in functions(strip_code(text)):
            if name in DATA_TABLES.get(f, ()):
                continue
            length = last - first + 1
            if length > FUNCTION_LIMIT:
                yield f"{f}:{first} {name} {length}"


def parse_known(path):
    known = {}
    if not os.path.exists(path):
        return known
    with open(path, encoding="utf-8") as fh:
        for raw in fh:
            raw = raw.strip()
            if not raw or raw.startswith("#"):
                continue
            key, size = raw.rsplit(" ", 1)
            known[key_of(key)] = int(size)
    return known


def key_of(entry):
    """A breach's identity without its line number: 'file file' or 'file function'."""
    where, what = entry.split(" ", 1)
    return where.split(":")[0] + " " + what


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--root", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    parser.add_argument("--list", action="store_true")
    args = parser.parse_args()
    found = list(breaches(args.root))
    if args.list:
        print("\n".join(found))
        return 0
    known = parse_known(os.path.join(args.root, "deploy", "size_limits_known.txt"))
    problems = []
    for entry in found:
        key, size = entry.rsplit(" ", 1)
        limit = known.get(key_of(key))
        if limit is None:
            kind = "lines" if " file " in entry else "lines in one function"
            problems.append(f"{key}: {size} {kind}, over the limit "
                            f"({FILE_LIMIT} per file, {FUNCTION_LIMIT} per function)")
        elif int(size) > limit:
            problems.append(f"{key}: grew from {limit} to {size} lines (listed in deploy/size_limits_known.txt: "
                            f"it may only shrink)")
    for line in problems:
        print("check_sizes: " + line)
    print(f"check_sizes: {len(found)} over a limit ({len(known)} known), {len(problems)} breach(es)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
