#!/usr/bin/env python3
"""Renders a JSON Schema's documented keys as a Markdown table (`| key | type | meaning |`, nested objects as
dotted keys, $ref followed), so that the docs explain every key of a JSON output from the schema it is
checked against. With --check DOC.md it compares the table with the one between the lines
`<!-- schema_table: SCHEMA -->` and `<!-- end schema_table -->` in DOC.md instead: exit 0 the same, 1 stale
(run with --write to update it), 2 unreadable input.

usage: schema_table.py SCHEMA.json [--check DOC.md | --write DOC.md]
"""
import json
import os
import sys


def rows(schema, root, prefix=""):
    out = []
    for key, sub in schema.get("properties", {}).items():
        while "$ref" in sub:
            sub = root["$defs"][sub["$ref"].split("/")[-1]]
        kind = sub.get("type", "")
        kind = " or ".join(kind) if isinstance(kind, list) else kind
        out.append((prefix + key, kind, " ".join(sub.get("description", "").split())))
        if "properties" in sub:
            out += rows(sub, root, prefix + key + ".")
        elif kind == "array" and "properties" in sub.get("items", {}):
            out += rows(sub["items"], root, prefix + key + "[].")
    return out


def table(schema_path):
    with open(schema_path) as f:
        schema = json.load(f)
    lines = ["| key | type | meaning |", "|---|---|---|"]
    lines += ["| `%s` | %s | %s |" % (k, t, d.replace("|", "\\|")) for k, t, d in rows(schema, schema)]
    return "\n".join(lines) + "\n"


def main(argv):
    if len(argv) not in (2, 4) or (len(argv) == 4 and argv[2] not in ("--check", "--write")):
        print(__doc__, file=sys.stderr)
        return 2
    try:
        text = table(argv[1])
        if len(argv) == 2:
            sys.stdout.write(text)
            return 0
        doc = argv[3]
        with open(doc) as f:
            content = f.read()
    except (OSError, ValueError, KeyError) as e:
        print("schema_table: %s" % e, file=sys.stderr)
        return 2
    begin = "<!-- schema_table: %s -->\n" % os.path.basename(argv[1])
    end = "<!-- end schema_table -->"
    i = content.find(begin)
    j = content.find(end, i)
    if i < 0 or j < 0:
        print("schema_table: %s has no '%s' ... '%s' block" % (doc, begin.strip(), end), file=sys.stderr)
        return 2
    current = content[i + len(begin):j]
    if argv[2] == "--write":
        tmp = doc + ".tmp"
        with open(tmp, "w") as f:
            f.write(content[:i + len(begin)] + text + content[j:])
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, doc)
        return 0
    if current != text:
        print("schema_table: the table in %s is not the schema's (python3 deploy/schema_table.py %s --write %s)"
              % (doc, argv[1], doc), file=sys.stderr)
        return 1
    print("schema_table: %s matches %s (%d keys)" % (doc, argv[1], text.count("\n") - 2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
