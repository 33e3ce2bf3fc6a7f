#!/usr/bin/env python3
"""Lists the production files that are too long and the functions that are too long.

One job per file: a file over 800 lines or a function over 100 lines is a sign to split
(DEVELOPERS.md). Production code is everything under engine/, plugins/ and tools/ that git tracks
(or, outside a git checkout, every file there); tests are not production code.

Usage: check-size.py [--root DIR] [--exceptions FILE] [--max-file-lines N] [--max-function-lines N]
                     [--all]

Exit status: 0 when every offender is listed in the exceptions page (docs/code-size.md) and
every exception still names an offender; 1 otherwise (an unlisted offender, a stale or malformed
exception); 2 on a usage error. --all prints the largest files and functions too. The test suite
runs it (ctest -L style).

Exceptions: the rows of the Markdown table(s) in the exceptions page whose first cell is a key in
backquotes, `path` for a file or `path:function` for a function (function as printed by this
script, e.g. `Foo::bar`), and whose second cell is the why, a non-empty sentence:
    | `engine/x/y.cpp:Foo::bar` | why it stays long |
Every other line of the page is prose and ignored.

Limits of the function scanner (a careful brace matcher, not a C++ parser):
  - Files counted: .c .cc .cpp .h .hpp (functions and lines) and .py .sh .cmake .txt
    (lines only).
  - Comments, string and character literals (including raw strings R"d(...)d") and
    preprocessor lines are blanked before scanning; code hidden behind #if branches is
    scanned as if every branch were compiled.
  - A brace block at namespace or class level is a function body when the text before it
    ends with a closing parenthesis, optionally followed by const, noexcept(...), override,
    final, mutable, &, && or a trailing return type; namespace, class, struct, union, enum and
    extern "C" blocks are descended into; any other block there (an initializer) is skipped.
    Brace initializers in a constructor's member-initializer list are recognised.
  - A function's length runs from the first line of its signature (after any comment)
    to its closing brace, both included. Lambdas and local classes count toward the
    function they are written in; a lambda at namespace level is not counted on its own.
  - Function-like macros that open a block (TEST(...) {) would count as functions; production
    code has none.
"""

import argparse
import os
import re
import subprocess
import sys

SOURCE_EXT = (".c", ".cc", ".cpp", ".h", ".hpp")
OTHER_EXT = (".py", ".sh", ".cmake", ".txt")
PRODUCTION_DIRS = ("engine", "plugins", "tools")

CONTAINER = re.compile(
    r'^(?:template\s*<.*>\s*)?(?:(?:inline\s+)?namespace\b|(?:class|struct|union|enum)\b|extern\s*""\s*$)',
    re.S)
# The end of a function signature: ')' and then qualifiers.
SIGNATURE_END = re.compile(
    r'\)\s*(?:(?:const|volatile|noexcept|override|final|mutable|&&|&|throw\s*\(\s*\)|noexcept\s*\([^()]*\))\s*)*'
    r'(?:->\s*[\w:<>,\s*&\[\]]+)?\s*$', re.S)
CONTROL = re.compile(r'^(?:if|for|while|switch|catch|do|else|return|try)\b')
CTOR_INIT = re.compile(r'\)\s*(?:noexcept\s*)?:(?!:)')
ACCESS = re.compile(r'\s*(?:(?:public|private|protected)\s*:(?!:)\s*)+')


def blank_code(text):
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    at_line_start = True
    while i < n:
        c = text[i]
        if at_line_start and c == "#":
            # A preprocessor line, with its backslash continuations.
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append(" \n")
                    i += 2
                    continue
                out.append(" ")
                i += 1
            continue
        if c in " \t":
            out.append(c)
            i += 1
            continue
        if c == "\n":
            out.append(c)
            at_line_start = True
            i += 1
            continue
        at_line_start = False
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and i + 1 < n and text[i + 1] == '"' and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            close = ")" + m.group(1) + '"'
            j = text.find(close, i + m.end())
            j = n if j < 0 else j + len(close)
            out.append('""' + re.sub(r"[^\n]", " ", text[i + 2:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum():  # a digit separator (1'000)
                out.append(" ")
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(c + " " * max(0, j - i - 2) + (c if j - i >= 2 else ""))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def match_brace(code, i):
    """Index just past the brace that closes the one at code[i]."""
    depth = 0
    for j in range(i, len(code)):
        if code[j] == "{":
            depth += 1
        elif code[j] == "}":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(code)


def function_name(header):
    """The qualified name of the function whose signature is header (text before its body)."""
    m = CTOR_INIT.search(header)
    h = header[:m.start() + 1] if m else header
    # Drop the parameter list: the last balanced (...) group before the qualifiers.
    depth, end = 0, None
    for k in range(len(h) - 1, -1, -1):
        if h[k] == ")":
            if depth == 0 and end is None:
                end = k
            depth += 1
        elif h[k] == "(":
            depth -= 1
            if depth == 0 and end is not None:
                m = re.search(r"((?:[\w~]+(?:<[^<>()]*>)?::)*(?:operator\s*(?:\(\)|[^\s(]+)|~?[\w]+))\s*$", h[:k])
                return m.group(1).replace(" ", "") if m else "?"
    return "?"


def scan_functions(code):
    """(name, first line, last line) of every function defined at namespace or class level."""
    found = []
    line_of = [0] * (len(code) + 1)
    ln = 1
    for k, ch in enumerate(code):
        line_of[k] = ln
        if ch == "\n":
            ln += 1
    line_of[len(code)] = ln

    def scan(start, end, prefix):
        header_start = start
        i = start
        while i < end:
            c = code[i]
            if c in ";":
                header_start = i + 1
            elif c == "}":
                header_start = i + 1
            elif c == "{":
                access = ACCESS.match(code, header_start, i)  # `public:` is not the signature's
                if access:
                    header_start = access.end()
                header = code[header_start:i]
                h = header.strip()
                close = match_brace(code, i)
                first = header_start + (len(header) - len(header.lstrip()))
                is_function = (SIGNATURE_END.search(h) and not CONTROL.match(h) and
                               "=" not in re.sub(r"\(.*\)", "", h, flags=re.S).split("operator")[0])
                if CONTAINER.match(h) and not is_function and "=" not in h:
                    m = re.match(r"(?:template\s*<.*>\s*)?(?:class|struct|union)\s+(?:\w+\s+)*?(\w+)\s*(?:final\s*)?(?::|$)", h, re.S)
                    scan(i + 1, close - 1, prefix + (m.group(1) + "::" if m else ""))
                    header_start = close
                    i = close
                    continue
                if is_function:
                    found.append((prefix + function_name(h), line_of[first], line_of[close - 1]))
                    header_start = close
                    i = close
                    continue
                if CTOR_INIT.search(h) and not SIGNATURE_END.search(h):
                    i = close  # a brace initializer of a member: the header goes on
                    continue
                header_start = close  # an initializer or anything else: skipped whole
                i = close
                continue
            i += 1

    scan(0, len(code), "")
    return found


def production_files(root):
    try:
        top = subprocess.run(["git", "-C", root, "rev-parse", "--show-toplevel"],
                             capture_output=True, text=True, check=True).stdout.strip()
        if not os.path.samefile(top, root):
            raise OSError("not the root of a git checkout")
        out = subprocess.run(["git", "-C", root, "ls-files", "--"] + list(PRODUCTION_DIRS),
                             capture_output=True, text=True, check=True).stdout.split("\n")
        files = [f for f in out if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d in PRODUCTION_DIRS:
            for dirpath, _, names in os.walk(os.path.join(root, d)):
                for nm in names:
                    files.append(os.path.relpath(os.path.join(dirpath, nm), root))
    return sorted(f for f in files if f.endswith(SOURCE_EXT + OTHER_EXT) and os.path.isfile(os.path.join(root, f)))


def read_exceptions(path):
    """{key: why} from the table rows of the page, and the malformed rows (line number, text)."""
    exceptions, bad = {}, []
    if not os.path.exists(path):
        return exceptions, bad
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            line = line.rstrip("\n")
            if not re.match(r"^\s*\|\s*`", line):
                continue  # prose, a header row or a separator row
            m = re.match(r"^\s*\|\s*`([^`\s]+)`\s*\|\s*([^|]*?\w[^|]*?)\s*\|\s*$", line)
            if not m or m.group(1) in exceptions:
                bad.append((number, line))
                continue
            exceptions[m.group(1)] = m.group(2)
    return exceptions, bad


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--root", default=os.path.dirname(here))
    ap.add_argument("--exceptions", default=None)
    ap.add_argument("--max-file-lines", type=int, default=800)
    ap.add_argument("--max-function-lines", type=int, default=100)
    ap.add_argument("--all", action="store_true", help="also print the ten largest files and functions")
    a = ap.parse_args()
    exceptions_path = a.exceptions or os.path.join(a.root, "docs", "code-size.md")
    exceptions, bad = read_exceptions(exceptions_path)

    files, functions = [], []
    for rel in production_files(a.root):
        with open(os.path.join(a.root, rel), encoding="utf-8", errors="replace") as f:
            text = f.read()
        files.append((text.count("\n") + (0 if text.endswith("\n") or not text else 1), rel))
        if rel.endswith(SOURCE_EXT):
            for name, first, last in scan_functions(blank_code(text)):
                functions.append((last - first + 1, rel + ":" + name, first))

    offenders = [(n, rel, "file", None) for n, rel in files if n > a.max_file_lines]
    offenders += [(n, key, "function", line) for n, key, line in functions if n > a.max_function_lines]
    status = 0
    for n, key, kind, line in sorted(offenders, key=lambda o: -o[0]):
        where = key if line is None else key.split(":")[0] + ":" + str(line) + ": " + key.split(":", 1)[1]
        limit = a.max_file_lines if kind == "file" else a.max_function_lines
        if key in exceptions:
            print(f"excepted  {where}: {kind} of {n} lines (over {limit}): {exceptions[key]}")
        else:
            print(f"TOO LONG  {where}: {kind} of {n} lines, over {limit}; split it by job "
                  f"or list it in {os.path.relpath(exceptions_path, a.root)} with why")
            status = 1
    offending = {key for _, key, _, _ in offenders}
    for key in sorted(set(exceptions) - offending):
        print(f"STALE     {key}: listed in {os.path.relpath(exceptions_path, a.root)} but not over its limit; remove it")
        status = 1
    for number, line in bad:
        print(f"{exceptions_path}:{number}: expected a row '| `path[:function]` | why |' naming a new key, got '{line}'")
        status = 1
    if a.all:
        print("largest files:")
        for n, rel in sorted(files, reverse=True)[:10]:
            print(f"  {n:6d}  {rel}")
        print("longest functions:")
        for n, key, line in sorted(functions, reverse=True)[:10]:
            print(f"  {n:6d}  {key} (line {line})")
    print(f"{len(files)} files, {len(functions)} functions read; "
          f"{len(offenders)} over the limits ({len(offenders) - len(offending - set(exceptions))} excepted)")
    return status


if __name__ == "__main__":
    sys.exit(main())
