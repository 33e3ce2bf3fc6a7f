"""tools/check-size.py on small trees written here: the line counts it reports are counted by hand
(a function's lines run from its signature to its closing brace), so a scanner that loses a brace
in a string, a comment or a lambda, or miscounts by one, fails these tests."""

import os
import subprocess
import sys

import pytest

SCRIPT = os.path.join(os.environ.get("KNEESIM_SOURCE_DIR",
                                     os.path.join(os.path.dirname(__file__), "..", "..")),
                      "tools", "check-size.py")


def function(name, body_lines, qualifiers=""):
    """A C++ function of exactly 2 + body_lines lines (signature, body, closing brace)."""
    body = "".join(f"  x += {i};\n" for i in range(body_lines))
    return f"int {name}(int x){qualifiers} {{\n{body}}}\n"


def run(root, *extra):
    r = subprocess.run([sys.executable, SCRIPT, "--root", str(root)] + list(extra),
                       capture_output=True, text=True)
    return r.returncode, r.stdout


def write(root, rel, text):
    path = root / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_a_function_of_101_lines_is_too_long_and_one_of_100_is_not(tmp_path):
    write(tmp_path, "engine/a/a.cpp", function("ok", 98) + function("big", 99))
    status, out = run(tmp_path)
    assert status == 1
    assert "TOO LONG  engine/a/a.cpp:101: big: function of 101 lines, over 100" in out
    assert ": ok:" not in out
    assert "1 files, 2 functions read; 1 over the limits (0 excepted)" in out


def test_braces_in_strings_comments_and_lambdas_do_not_end_the_function(tmp_path):
    text = ("namespace n {\n"
            "class Foo {\n"
            " public:\n"
            "  int bar(int x) const {\n"           # line 4
            "    const char* s = \"}}}\";  // }\n"
            "    /* } */ auto f = [&](int y) { return y + 1; };\n"
            "    const char* r = R\"d(\n}\n)d\";\n"  # 3 lines
            + "".join("    x += f(x);\n" for _ in range(93)) +
            "    return x;\n"
            "  }\n"                                # line 104: 101 lines
            "};\n"
            "}  // namespace n\n")
    write(tmp_path, "engine/a/b.hpp", text)
    status, out = run(tmp_path)
    assert status == 1
    assert "engine/a/b.hpp:4: Foo::bar: function of 101 lines" in out


def test_a_file_of_801_lines_is_too_long(tmp_path):
    write(tmp_path, "plugins/p/long.c", "int x;\n" * 801)
    write(tmp_path, "tools/t/fine.py", "x = 1\n" * 800)
    write(tmp_path, "tests/t/ignored.cpp", "int x;\n" * 900)  # tests are not production code
    status, out = run(tmp_path)
    assert status == 1
    assert "TOO LONG  plugins/p/long.c: file of 801 lines, over 800" in out
    assert "fine.py" not in out and "ignored" not in out


def test_an_excepted_offender_passes_and_a_stale_or_malformed_exception_fails(tmp_path):
    write(tmp_path, "engine/a/a.cpp", function("big", 99))
    page = ("# Code size\n\nSome prose with `engine/a/a.cpp:big` in it.\n\n"
            "| what | why |\n| --- | --- |\n"
            "| `engine/a/a.cpp:big` | it is one formula that reads best whole |\n")
    write(tmp_path, "docs/code-size.md", page)
    status, out = run(tmp_path)
    assert status == 0, out
    assert "excepted  engine/a/a.cpp:1: big: function of 101 lines (over 100): it is one formula" in out

    write(tmp_path, "docs/code-size.md", page + "| `engine/a/gone.cpp` | it was long once |\n")
    status, out = run(tmp_path)
    assert status == 1
    assert "STALE     engine/a/gone.cpp" in out

    write(tmp_path, "docs/code-size.md", page + "| `engine/a/a.cpp` |  |\n")
    status, out = run(tmp_path)
    assert status == 1
    assert "docs/code-size.md:8: expected a row" in out


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-q"]))
