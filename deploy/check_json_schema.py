#!/usr/bin/env python3
"""Checks a JSON document (or a part of it) against a JSON Schema, the subset the project's schemas use:
type (one or a list), required, properties, additionalProperties (false or a schema), items, enum,
minimum and $ref to "#/$defs/NAME". Prints every mismatch with its path; exit 0 valid, 1 invalid,
2 unreadable input or a schema keyword it does not know.

usage: check_json_schema.py SCHEMA.json DOCUMENT.json [--pointer /server]
"""
import json
import sys

TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "null": lambda v: v is None,
}
KNOWN = {"$schema", "$id", "$defs", "$ref", "title", "description", "type", "required", "properties",
         "additionalProperties", "items", "enum", "minimum"}


class SchemaError(Exception):
    pass


def check(schema, value, path, root, errors):
    unknown = set(schema) - KNOWN
    if unknown:
        raise SchemaError(f"{path or '/'}: schema keywords not supported: {sorted(unknown)}")
    if "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/$defs/") or ref[8:] not in root.get("$defs", {}):
            raise SchemaError(f"{path or '/'}: unresolved $ref {ref}")
        check(root["$defs"][ref[8:]], value, path, root, errors)
    if "type" in schema:
        types = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(TYPES[t](value) for t in types):
            errors.append(f"{path or '/'}: {type(value).__name__} {json.dumps(value)[:60]}, expected {'|'.join(types)}")
            return
    if "enum" in schema and value not in schema["enum"]:
        errors.append(f"{path or '/'}: {json.dumps(value)} is not one of {schema['enum']}")
    if "minimum" in schema and TYPES["number"](value) and value < schema["minimum"]:
        errors.append(f"{path or '/'}: {value} is below the minimum {schema['minimum']}")
    if isinstance(value, dict):
        props = schema.get("properties", {})
        for key in schema.get("required", []):
            if key not in value:
                errors.append(f"{path}/{key}: missing")
        extra = schema.get("additionalProperties", True)
        for key, v in value.items():
            if key in props:
                check(props[key], v, f"{path}/{key}", root, errors)
            elif extra is False:
                errors.append(f"{path}/{key}: not in the schema")
            elif isinstance(extra, dict):
                check(extra, v, f"{path}/{key}", root, errors)
    if isinstance(value, list) and "items" in schema:
        for i, v in enumerate(value):
            check(schema["items"], v, f"{path}/{i}", root, errors)


def main(argv):
    if len(argv) not in (3, 5) or (len(argv) == 5 and argv[3] != "--pointer"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    try:
        with open(argv[1]) as f:
            schema = json.load(f)
        with open(argv[2]) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        print(f"check_json_schema: {e}", file=sys.stderr)
        return 2
    pointer = argv[4] if len(argv) == 5 else ""
    for part in filter(None, pointer.split("/")):
        if not isinstance(doc, dict) or part not in doc:
            print(f"{argv[2]}: no {pointer} in the document", file=sys.stderr)
            return 1
        doc = doc[part]
    errors = []
    try:
        check(schema, doc, "", schema, errors)
    except SchemaError as e:
        print(f"check_json_schema: {argv[1]}: {e}", file=sys.stderr)
        return 2
    for e in errors:
        print(f"{argv[2]}{pointer}: {e}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
