"""gen_params.py [--check] - write docs/parameters.md from `infilld engines`.

The parameter reference is generated from the binary's own description, so
it cannot drift from the code; tests/docs/test_docs.py runs --check.
"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = os.environ.get("INFILLD_BIN", os.path.join(ROOT, "build", "infilld"))
DOC = os.path.join(ROOT, "docs", "parameters.md")


def fmt_num(v):
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return f"{v:g}" if isinstance(v, float) else str(v)


def rng(p):
    if p["type"] in ("int", "number", "vec3"):
        lo = "(" if p.get("min_exclusive") else "["
        hi = ")" if p.get("max_exclusive") else "]"
        return f"{lo}{fmt_num(p['min'])}, {fmt_num(p['max'])}{hi}"
    if p["type"] == "enum":
        return " \\| ".join(f"`{c}`" for c in p["choices"])
    if p["type"] == "string":
        return f"up to {p['max_length']} chars"
    return "true \\| false"


def default(p):
    d = p["default"]
    if isinstance(d, bool):
        return "true" if d else "false"
    if isinstance(d, list):
        return ",".join(fmt_num(x) for x in d)
    if isinstance(d, (int, float)):
        return fmt_num(d)
    return f"`{d}`" if d else '""'


def table(params):
    out = ["| key | type | unit | default | accepted | meaning |",
           "|---|---|---|---|---|---|"]
    for p in params:
        notes = p["help"]
        if p.get("zero_means_auto"):
            notes += " (0 = automatic)"
        if p.get("cli_only"):
            notes += " (command line only: a local file)"
        out.append(f"| `{p['name']}` | {p['type']} | {p['unit'] or '-'} | {default(p)} | "
                   f"{rng(p)} | {notes} |")
    return "\n".join(out)


def render(d):
    s = ["# Parameters", "",
         "Generated from `infilld engines` by `tests/docs/gen_params.py`; do not edit by hand.",
         "", "Every key is set the same way everywhere: `--set KEY=VALUE` on the command line, a "
         "JSON object in `--params FILE.json`, or the `params` object of `POST /v1/jobs` (JSON "
         "types: numbers for number/int, booleans for bool, strings for enum/string, `[x, y, z]` "
         "for vec3). A key is looked up in the common table, then the engine's, then the "
         "printer's settings; an unknown key is an error naming it.", "",
         "## Common keys (every job)", "", table(d["common_params"]), ""]
    for e in d["engines"]:
        s += [f"## Engine `{e['name']}`", "", e["summary"], ""]
        if e["paper"]:
            s += [f"Method: {e['paper']}", ""]
        s += [table(e["params"]) if e["params"] else "No parameters of its own.", ""]
    s += ["## Printer profiles", "",
          "`--printer NAME` picks a profile (default from the format: sl1 -> `sl1`, sl1s -> "
          "`sl1s`, zip -> `sl1`, gcode -> `generic-fdm`); its settings are keys too.", ""]
    for p in d["printers"]:
        s += [f"### `{p['name']}` ({p['kind']})", "", table(p["settings"]), ""]
    s += ["## Output formats", "", "| format | extension | media type | default printer |",
          "|---|---|---|---|"]
    for f in d["formats"]:
        s.append(f"| `{f['name']}` | `{f['extension']}` | `{f['media_type']}` | "
                 f"{f['default_printer'] or '-'} |")
    return "\n".join(s) + "\n"


def main():
    d = json.loads(subprocess.run([BIN, "engines"], check=True, capture_output=True,
                                  text=True).stdout)
    text = render(d)
    if "--check" in sys.argv:
        cur = open(DOC).read() if os.path.exists(DOC) else ""
        if cur != text:
            sys.exit("docs/parameters.md is out of date: run python3 tests/docs/gen_params.py")
        return
    with open(DOC, "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
