#!/usr/bin/env python3
"""Writes the libFuzzer dictionaries fuzz/dict/<target>.dict: the words the target's reader looks
for (every identifier-like string literal of its sources: element names, keys, units, parameter
names), as XML tags for the XML readers, plus the syntax and the numbers readers choke on.

    python3 fuzz/seeds/make_dicts.py            (from the repository's root)
"""
import glob
import os
import re

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))

# Target -> (kind, the reader's sources).
TARGETS = {
    "c3d": ("binary", ["engine/io/c3d.cpp", "engine/io/c3d_parameters.cpp", "engine/io/c3d_plates.cpp"]),
    "trc": ("text", ["engine/io/trc.cpp", "engine/io/text_fields.cpp"]),
    "storage": ("text", ["engine/io/storage.cpp", "engine/io/text_fields.cpp"]),
    "csv": ("text", ["engine/io/csv.cpp"]),
    "knee_forces": ("text", ["engine/io/knee_forces.cpp", "engine/io/csv.cpp"]),
    "stl_ascii": ("text", ["engine/io/stl.cpp"]),
    "osim": ("xml", ["engine/model/osim_*.cpp", "engine/model/function.cpp"]),
    "actuator_set": ("xml", ["engine/model/osim_forces.cpp", "engine/model/function.cpp"]),
    "urdf": ("xml", ["engine/model/urdf.cpp"]),
    "ik_setup": ("xml", ["engine/ik/tool.cpp"]),
    "ik_tasks": ("xml", ["engine/ik/tool.cpp"]),
    "marker_placer": ("xml", ["engine/ik/marker_placer.cpp", "engine/ik/tool.cpp"]),
    "id_setup": ("xml", ["engine/dynamics/tool.cpp", "engine/dynamics/knee_loads.cpp"]),
    "external_loads": ("xml", ["engine/dynamics/external_loads.cpp"]),
    "analyze_setup": ("xml", ["engine/muscle/analyze_tool.cpp"]),
    "gap_setup": ("xml", ["engine/gap/tool.cpp", "engine/gap/trial_inputs.cpp"]),
    "gap_model": ("json", ["engine/gap/prediction.cpp"]),
    "contact_area_setup": ("xml", ["engine/tool/contact_area_tool.cpp"]),
    "workflow_setup": ("xml", ["engine/tool/workflow_setup.cpp", "engine/tool/workflow_muscles.cpp"]),
    "plugin_parameters": ("xml", ["engine/tool/workflow_setup.cpp", "plugins/hertz/hertz.c",
                                  "plugins/elastic_foundation/elastic_foundation.c"]),
    "knee_model_setup": ("xml", ["engine/tool/knee_model_setup.cpp"]),
    "batch_trial": ("xml", ["engine/tool/batch_trial.cpp"]),
    "batch_manifest_csv": ("text", ["engine/tool/batch_manifest.cpp"]),
    "batch_manifest_toml": ("toml", ["engine/tool/batch_manifest.cpp"]),
}

NUMBERS = ["0", "-1", "1e308", "-1e308", "1e-320", "nan", "NaN", "inf", "-inf", "Infinity", "2147483648",
           "4294967296", "9223372036854775808", "1e10", "0x10", "1.5", "-0"]
XML = ['<?xml version="1.0" encoding="UTF-8"?>', "<OpenSimDocument Version=\"40000\">", "</OpenSimDocument>",
       "<!--", "-->", "<![CDATA[", "]]>", "&amp;", "&lt;", "&#65;", "&#x10FFFF;", "<!DOCTYPE", "<!ENTITY",
       " name=\"", "/>", "<objects>", "</objects>", "<groups/>", "true", "false"]
TOML = ["[[trial]]", "[defaults]", "[trial]", " = ", "\"\"\"", "'''", "[", "]", "{", "}", "true", "false",
        "1979-05-27T07:32:00Z", "0x7fffffffffffffff"]
JSON = ["{", "}", "[", "]", "\":", "null", "true", "false", "\"\\u0000\"", "\"\\ud800\""]


def literals(patterns):
    words = set()
    for pattern in patterns:
        for path in glob.glob(os.path.join(ROOT, pattern)):
            text = open(path).read()
            words.update(re.findall(r'"([A-Za-z_][A-Za-z0-9_.:#]{0,40})"', text))
    return sorted(words)


def quote(s):
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def main():
    out = os.path.join(ROOT, "fuzz", "dict")
    os.makedirs(out, exist_ok=True)
    for target, (kind, sources) in TARGETS.items():
        tokens = []
        for w in literals(sources):
            tokens.append(w)
            if kind == "xml" and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", w):
                tokens += ["<%s>" % w, "</%s>" % w]
            if kind == "json":
                tokens.append('"%s":' % w)
        tokens += NUMBERS + {"xml": XML, "toml": TOML, "json": JSON}.get(kind, [])
        with open(os.path.join(out, target + ".dict"), "w") as f:
            f.write("# Made by fuzz/seeds/make_dicts.py from %s.\n" % ", ".join(sources))
            for t in dict.fromkeys(tokens):
                f.write(quote(t) + "\n")


if __name__ == "__main__":
    main()
