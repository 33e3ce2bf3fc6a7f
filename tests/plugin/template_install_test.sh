#!/bin/sh
# Installs kneesim's "engine" component into a temporary prefix, builds plugins/template against
# it as a standalone project, and loads the result through plugin::Registry (a test in test_plugin
# that runs only when KNEESIM_TEMPLATE_PLUGIN is set).
#   template_install_test.sh <build dir> <source dir> <test_plugin executable> <libkneesim_engine>
set -eu
build=$1 src=$2 test_exe=$3 engine_lib=$4
if [ ! -f "$engine_lib" ]; then
  echo "SKIP: $engine_lib is not built (build the kneesim_engine target first)"
  exit 77
fi
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_template.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM

cmake --install "$build" --prefix "$tmp/prefix" --component engine >"$tmp/install.log" 2>&1 \
  || { cat "$tmp/install.log"; echo "FAIL: installing the engine component"; exit 1; }
test -f "$tmp/prefix/include/kneesim/plugin/kneesim_plugin.h" || { echo "FAIL: ABI header not installed"; exit 1; }

cmake -S "$src/plugins/template" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" -DCMAKE_BUILD_TYPE=Release \
  >"$tmp/configure.log" 2>&1 || { cat "$tmp/configure.log"; echo "FAIL: configuring the template"; exit 1; }
cmake --build "$tmp/build" >"$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; echo "FAIL: building the template"; exit 1; }
plugin="$tmp/build/libkneesim_my_law.so"
test -f "$plugin" || { echo "FAIL: $plugin was not built"; exit 1; }
# Only the registration function may be exported.
if command -v nm >/dev/null 2>&1; then
  exported=$(nm -D --defined-only "$plugin" | awk '$2 == "T" {print $3}')
  [ "$exported" = "kneesim_plugin_register" ] || { echo "FAIL: exported symbols: $exported"; exit 1; }
fi

effect="$tmp/build/libkneesim_my_effect.so"
test -f "$effect" || { echo "FAIL: $effect was not built"; exit 1; }
KNEESIM_TEMPLATE_PLUGIN="$plugin" KNEESIM_TEMPLATE_EFFECT="$effect" "$test_exe" --gtest_filter='TemplatePlugin.*' >"$tmp/test.log" 2>&1 \
  || { cat "$tmp/test.log"; echo "FAIL: loading the template plugin"; exit 1; }
cat "$tmp/test.log"
grep -q '^\[       OK \] TemplatePlugin.LoadsAndComputes' "$tmp/test.log" \
  || { echo "FAIL: TemplatePlugin.LoadsAndComputes did not run"; exit 1; }
grep -q '^\[       OK \] TemplatePlugin.EffectLoadsAndIsNested' "$tmp/test.log" \
  || { echo "FAIL: TemplatePlugin.EffectLoadsAndIsNested did not run"; exit 1; }
echo "template plugin built against the installed package and loaded: OK"
