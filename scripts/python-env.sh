#!/usr/bin/env bash
# The Python environments of the tests that use another ecosystem's own tools, each a virtual
# environment outside the repository ($DYNOTRAJ_VENV's parent, else ~/.cache), made once and
# made again when its pins change:
#   readers     tests/python/requirements.txt (mcap, rosbags, jsonschema)
#   ray         fleet/requirements.txt
#   rerun       tests/python/rerun-requirements.txt
#   kitti2mcap  tests/python/kitti2mcap-requirements.txt
# `python-env.sh NAME` makes NAME's environment if needed and prints its python (the tests call
# it); with no argument it makes all four (scripts/test.sh starts that beside the build, so the
# downloads overlap the compiling). Tests run in processes of their own and may ask at once: a
# lock per environment makes one of them install while the others wait.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"

# NAME's folder and requirements file, as "FOLDER REQUIREMENTS" (the path may hold spaces).
env_of() {
  case "$1" in
    readers) echo "dynotraj-venv $root/tests/python/requirements.txt" ;;
    ray) echo "dynotraj-ray-venv $root/fleet/requirements.txt" ;;
    rerun) echo "dynotraj-rerun-venv $root/tests/python/rerun-requirements.txt" ;;
    kitti2mcap) echo "dynotraj-kitti2mcap-venv $root/tests/python/kitti2mcap-requirements.txt" ;;
    *) echo "python-env: unknown environment '$1' (expected readers, ray, rerun or kitti2mcap)" >&2; return 2 ;;
  esac
}

make_env() {
  local name="$1" env requirements folder parent venv
  env=$(env_of "$name")
  read -r folder requirements <<<"$env"
  if [ -n "${DYNOTRAJ_VENV:-}" ]; then
    parent=$(dirname "$DYNOTRAJ_VENV")
  else
    parent="${HOME:?neither DYNOTRAJ_VENV nor HOME is set}/.cache"
  fi
  mkdir -p "$parent"
  venv="$parent/$folder"
  exec 9>"$venv.lock"
  flock 9
  # The requirements the environment was completed with: a change of pins installs again.
  if [ -x "$venv/bin/python" ] && cmp -s "$requirements" "$venv/dynotraj-requirements.txt"; then
    echo "$venv/bin/python"
    return 0
  fi
  command -v python3 >/dev/null || { echo "python-env: python3 not found" >&2; return 1; }
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv" >&2 || { echo "python-env: python3 -m venv $venv failed" >&2; return 1; }
  "$venv/bin/python" -m pip --version >/dev/null || { echo "python-env: no pip in $venv" >&2; return 1; }
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$requirements" >&2 ||
    { echo "python-env: pip install -r $requirements failed (above)" >&2; return 1; }
  cp "$requirements" "$venv/dynotraj-requirements.txt"
  echo "$venv/bin/python"
}

if [ $# -eq 0 ]; then
  status=0
  for name in readers ray rerun kitti2mcap; do
    (make_env "$name") || status=1
  done
  exit "$status"
fi
make_env "$1"
