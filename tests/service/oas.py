"""oas.py - check JSON responses against openapi.yaml's schemas.

openapi.yaml is converted to JSON with js-yaml (node_modules, installed
by `make deps`); this file implements the JSON Schema subset the contract
uses: type (incl. lists), enum, const, required, properties,
additionalProperties, items, min/maxItems, minimum/maximum, min/maxLength,
pattern, oneOf, allOf, $ref."""
import json
import os
import re
import subprocess

from svc import ROOT

_spec = None


def spec():
    global _spec
    if _spec is None:
        js = ("const y=require('js-yaml');const fs=require('fs');"
              "process.stdout.write(JSON.stringify(y.load(fs.readFileSync(process.argv[1],'utf8'))))")
        out = subprocess.run(["node", "-e", js, os.path.join(ROOT, "openapi.yaml")],
                             capture_output=True, text=True, cwd=ROOT, timeout=60,
                             env=dict(os.environ, NODE_PATH=os.path.join(ROOT, "node_modules")))
        if out.returncode != 0:
            raise AssertionError("cannot load openapi.yaml (run make deps): " + out.stderr)
        _spec = json.loads(out.stdout)
    return _spec


def resolve(s):
    while isinstance(s, dict) and "$ref" in s:
        node = spec()
        for part in s["$ref"].lstrip("#/").split("/"):
            node = node[part]
        s = node
    return s


TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
}


def errors(v, s, path="$"):
    """List of violations of schema s by value v."""
    s = resolve(s)
    out = []
    if "allOf" in s:
        for sub in s["allOf"]:
            out += errors(v, sub, path)
    if "oneOf" in s:
        ok = [sub for sub in s["oneOf"] if not errors(v, sub, path)]
        if len(ok) != 1:
            out.append("%s: matches %d of oneOf" % (path, len(ok)))
    t = s.get("type")
    if t is not None:
        ts = t if isinstance(t, list) else [t]
        if not any(TYPES[x](v) for x in ts):
            return out + ["%s: %r is not %s" % (path, v, t)]
    if "enum" in s and v not in s["enum"]:
        out.append("%s: %r not in %s" % (path, v, s["enum"]))
    if "const" in s and v != s["const"]:
        out.append("%s: %r != %r" % (path, v, s["const"]))
    if isinstance(v, str):
        if "pattern" in s and not re.search(s["pattern"], v):
            out.append("%s: %r does not match %s" % (path, v, s["pattern"]))
        if len(v) < s.get("minLength", 0) or len(v) > s.get("maxLength", 1 << 62):
            out.append("%s: length %d out of range" % (path, len(v)))
    if TYPES["number"](v):
        if "minimum" in s and v < s["minimum"]:
            out.append("%s: %r < %r" % (path, v, s["minimum"]))
        if "maximum" in s and v > s["maximum"]:
            out.append("%s: %r > %r" % (path, v, s["maximum"]))
    if isinstance(v, dict):
        for k in s.get("required", []):
            if k not in v:
                out.append("%s: missing %s" % (path, k))
        props = s.get("properties", {})
        extra = s.get("additionalProperties", True)
        for k, x in v.items():
            if k in props:
                out += errors(x, props[k], path + "." + k)
            elif extra is False:
                out.append("%s: unexpected %s" % (path, k))
            elif isinstance(extra, dict):
                out += errors(x, extra, path + "." + k)
    if isinstance(v, list):
        if len(v) < s.get("minItems", 0) or len(v) > s.get("maxItems", 1 << 62):
            out.append("%s: %d items out of range" % (path, len(v)))
        if "items" in s:
            for i, x in enumerate(v):
                out += errors(x, s["items"], "%s[%d]" % (path, i))
    return out


def response_schema(method, template, status, ctype):
    op = spec()["paths"][template][method.lower()]
    resp = resolve(op["responses"][str(status)])
    return resolve(resp["content"][ctype]["schema"])


def check_response(method, template, resp):
    """Assert resp (svc.Resp) is documented and its JSON body conforms."""
    ctype = (resp.header("Content-Type") or "").split(";")[0]
    paths = spec()["paths"]
    if template not in paths or method.lower() not in paths[template]:
        raise AssertionError("%s %s is not in openapi.yaml" % (method, template))
    if str(resp.status) not in paths[template][method.lower()]["responses"]:
        raise AssertionError("%s %s: status %d not documented" % (method, template, resp.status))
    if not resp.body or not ctype.endswith("json"):
        return
    errs = errors(json.loads(resp.body), response_schema(method, template, resp.status, ctype))
    if errs:
        raise AssertionError("%s %s %d violates openapi.yaml: %s" % (method, template,
                                                                   resp.status, errs[:5]))


def schema(name):
    return spec()["components"]["schemas"][name]
