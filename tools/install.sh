#!/bin/sh
# Installs what ./build holds (run after a build: run-main-job.sh calls it): the kneesim command,
# the engine library, plugins, headers, share/ and the Python module `kneesim`, into the configured
# prefix (default /usr/local; $HOME/.local when that is not writable). The module goes where the
# interpreter it was built for looks under that prefix (Debian: /usr/local/lib/python3.X/dist-packages),
# and again into the site-packages of python3 on PATH when that is another interpreter with the
# same ABI (e.g. pyenv's), so `python3 -c "import kneesim"` works for the python3 users type.
set -eu
cd "$(dirname "$0")/.."
[ -f build/CMakeCache.txt ] || { echo "install.sh: no build/ (run ./tools/run-main-job.sh first)" >&2; exit 1; }
prefix=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' build/CMakeCache.txt)
if ! { mkdir -p "$prefix" 2>/dev/null && [ -w "$prefix" ]; }; then
  # Not root: a per-user install; the engine's plugin folder is compiled in, hence the rebuild.
  prefix="$HOME/.local"
  echo "== $prefix is used: the configured prefix is not writable"
  cmake -S . -B build -DCMAKE_INSTALL_PREFIX="$prefix" >/dev/null
  cmake --build build -j"$(nproc)"
fi
cmake --install build >/dev/null
cmake --install build --component python-site >/dev/null
echo "== kneesim installed into $prefix"
if command -v python3 >/dev/null 2>&1; then
  if python3 -c "import kneesim" 2>/dev/null; then
    echo "   python3 -c 'import kneesim' works: $(python3 -c 'import kneesim; print(kneesim.__file__)')"
  else
    echo "   python3 on PATH ($(command -v python3)) cannot import kneesim: it has another ABI than" \
         "$(sed -n 's/^Python_EXECUTABLE:FILEPATH=//p' build/CMakeCache.txt); use that interpreter" >&2
  fi
fi
