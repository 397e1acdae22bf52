#!/usr/bin/env bash
# The Python package's check, as CI runs it (its "python" step): the wheel built (abi3, with
# maturin, sharing the repository's target/), installed into a fresh venv, the README's Python
# section run there, then the package's tests (the API against the CLI's bits, terms written in
# Python, the example notebook executed by nbclient, the dask sweep on a LocalCluster). Python and
# venv from Debian where missing; everything else from PyPI (the packages it names at the
# versions of check-constraints.txt). Run from anywhere: bash crates/lancer-py/check.sh
set -euo pipefail
cd "$(dirname "$0")/../.."
export CARGO_TERM_COLOR=never
step() { echo "[python ${SECONDS}s] $*"; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
step "lints"
if ! command -v python3 >/dev/null 2>&1 || ! python3 -c "import ensurepip, venv" >/dev/null 2>&1; then
  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q python3 python3-venv
fi
cargo fmt --manifest-path crates/lancer-py/Cargo.toml --check
CARGO_TARGET_DIR="$PWD/target" cargo clippy --manifest-path crates/lancer-py/Cargo.toml --locked -- -D warnings
cargo build --release --locked -p lancer-cli
step "wheel"
# The packages named here (and NumPy) at the versions of check-constraints.txt.
constraints="$PWD/crates/lancer-py/check-constraints.txt"
python3 -m venv "$out/build-venv"
"$out/build-venv/bin/pip" install -q --disable-pip-version-check -c "$constraints" maturin
(cd crates/lancer-py && CARGO_TARGET_DIR="$PWD/../../target" "$out/build-venv/bin/maturin" build \
  --release --locked --out "$out/wheels")
python3 -m venv "$out/venv"
"$out/venv/bin/pip" install -q --disable-pip-version-check -c "$constraints" "$out"/wheels/lancer-*.whl
step "README section"
readme_md="$PWD/README.md"
mkdir "$out/readme" && ln -s "$PWD/scenes" "$out/readme/scenes"
(cd "$out/readme" && "$out/venv/bin/python" -c '
import pathlib, re, sys
readme = pathlib.Path(sys.argv[1]).read_text()
section = readme.split("\n## In Python and Jupyter\n")[1].split("\n## ")[0]
blocks = re.findall(r"```python\n(.*?)```", section, re.S)
assert len(blocks) >= 2, "the README lost its Python examples"
namespace = {}
for block in blocks:
    exec(compile(block, "README.md (In Python and Jupyter)", "exec"), namespace)
' "$readme_md")
test -s "$out/readme/glass.png" && test -s "$out/readme/glass-aov/beauty.exr"
step "test tools"
"$out/venv/bin/pip" install -q --disable-pip-version-check -c "$constraints" pytest nbclient nbformat \
  ipykernel ipywidgets matplotlib "dask[distributed]"
step "tests"
# Every test runs here: a skip (a missing module or binary) fails the step.
LANCER_CLI="$PWD/target/release/lancer" "$out/venv/bin/python" -m pytest -q -rs -p no:cacheprovider \
  crates/lancer-py/tests | tee "$out/pytest.log"
if grep -q "skipped" "$out/pytest.log"; then echo "python: tests were skipped" >&2; exit 1; fi

