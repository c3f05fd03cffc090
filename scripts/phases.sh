# Sourced by the scripts: where a run's time goes. `phase NAME` ends the phase before and
# starts NAME (printing `== NAME`); `phase_table` ends the last one and prints every phase's
# wall seconds and the total as a table, so that a change to the scripts or the build is
# measured by the phase it moves.
_phase_names=()
_phase_secs=()
_phase_name=""
_phase_start=$(date +%s.%N)
_phase_begin=$_phase_start

# Seconds since the `date +%s.%N` reading $1.
_phase_since() {
  awk -v now="$(date +%s.%N)" -v then="$1" 'BEGIN { printf "%.3f", now - then }'
}

_phase_end() {
  if [ -n "$_phase_name" ]; then
    _phase_names+=("$_phase_name")
    _phase_secs+=("$(_phase_since "$_phase_start")")
  fi
  _phase_name=""
}

phase() {
  _phase_end
  _phase_name="$1"
  _phase_start=$(date +%s.%N)
  echo "== $1"
}

phase_table() {
  _phase_end
  local i total
  total=$(_phase_since "$_phase_begin")
  echo "| phase | wall s |"
  echo "|---|---:|"
  for i in "${!_phase_names[@]}"; do
    printf '| %s | %.1f |\n' "${_phase_names[$i]}" "${_phase_secs[$i]}"
  done
  printf '| total | %.1f |\n' "$total"
}
