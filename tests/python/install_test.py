"""`cmake --install` of the components "engine" and "python" gives a package that imports from
its install folder and loads the engine installed beside it (RUNPATH relative to the module), in
a temporary prefix so the test leaves the machine as it was."""

import os
import pathlib
import subprocess
import sys

from conftest import source_path


def test_the_installed_package_imports_and_uses_its_own_engine(tmp_path):
    build = os.environ["KNEESIM_BINARY_DIR"]
    prefix = tmp_path / "prefix"
    for component in ("engine", "python"):
        subprocess.run(["cmake", "--install", build, "--prefix", str(prefix), "--component", component],
                       check=True, capture_output=True)
    inits = list(prefix.glob("lib/**/kneesim/__init__.py"))
    assert len(inits) == 1, inits
    site = inits[0].parent.parent
    code = ("import kneesim; m = kneesim.load_model(%r); print(kneesim.__file__); print(m.name); "
            "print([l.split()[-1] for l in open('/proc/self/maps') if 'libkneesim_engine' in l][0])"
            % str(source_path("tests/tool/fixtures/slider_knee.osim")))
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LD_LIBRARY_PATH")}
    env["PYTHONPATH"] = str(site)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    module, name, engine = out.stdout.split()
    assert pathlib.Path(module) == inits[0]
    assert name == "slider_knee"
    assert pathlib.Path(engine).resolve().parent == (prefix / "lib").resolve()
