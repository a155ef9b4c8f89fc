# Sourced by the reproduction tests, which send their script's stderr to a
# log file: when the test fails, the end of that log goes to ctest's output,
# which CI keeps, instead of staying only in a file the next run overwrites.
#   show_log_on_failure LOG
show_log_on_failure() {
  _skidimm_log=$1
  trap 'code=$?; if [ "$code" -ne 0 ] && [ -s "$_skidimm_log" ]; then
          echo "the end of $_skidimm_log (exit $code):" >&2; tail -n 40 "$_skidimm_log" >&2; fi' EXIT
}
