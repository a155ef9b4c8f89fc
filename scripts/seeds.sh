# The seeds of every simulated log the project's scripts fit, tune or choose
# defaults on, and of the logs they score; sourced by those scripts, which
# take their seeds from here (no script keeps a copy), and whose
# check_disjoint fails loudly if a scored seed was also used to fit, tune or
# choose anything. That check covers what scripts do. It cannot cover what
# people did while developing: the stc_traction model was reworked over
# several commits while its scores on the paper's scored seeds (5001-5020)
# were read, so those seeds shaped a model choice, though no value was fitted
# or tuned on them. docs/results.md says so, and scores the traction banks on
# the seeds kept for such choices (model_selection_seeds) next to the scored
# ones.
#   source scripts/seeds.sh

# scripts/fit_bundled_configs.sh: the first seed of each set of fitting logs,
# one seed per mode from there (LTC: 3 terrains, STC: 16 slip modes), each
# driven through four maneuvers (seed * 10 + maneuver): the ideal sensors'
# fitting logs, and with a Husky-class robot's sensors, fitting logs and
# tuning logs (estimating R).
bundled_fit_first_seed() {  # bundled_fit_first_seed ideal|realistic|realistic_tune ltc|stc
  case "$1 $2" in
    "ideal ltc") echo 100 ;;
    "ideal stc") echo 200 ;;
    "realistic ltc") echo 110 ;;
    "realistic stc") echo 220 ;;
    "realistic_tune ltc") echo 120 ;;
    "realistic_tune stc") echo 240 ;;
    *) echo "bundled_fit_first_seed: no set '$1 $2'" >&2; return 1 ;;
  esac
}
bundled_fit_modes() { case $1 in ltc) echo 3 ;; stc) echo 16 ;; esac; }
bundled_fit_seeds() {
  local set model first s i
  for set in ideal realistic realistic_tune; do
    for model in ltc stc; do
      first=$(bundled_fit_first_seed "$set" "$model")
      for s in $(seq "$first" $((first + $(bundled_fit_modes "$model") - 1))); do
        for i in 0 1 2 3; do echo $((s * 10 + i)); done
      done
    done
  done
}
# scripts/reproduce_tuning.sh: fitting drivers and tuning logs.
tuning_fit_seeds() { seq 7001 7003; seq 7011 7020; }
# The switching logs on which the decision's default settings are weighed
# against others (scripts/reproduce_paper.sh, docs/results.md).
decision_default_seeds() { seq 8101 8120; }
# Spirals (the four slip configurations' scenarios) on which choices about
# stc_traction and its bank were checked once the scored seeds had been read
# while developing it (the skid growth per side, how far the gyro's noise may
# be trusted). No bank or setting is fitted or tuned on them;
# scripts/reproduce_paper.sh scores the traction banks on them next to the
# scored seeds (docs/results.md, "How the traction model was chosen").
model_selection_seeds() { seq 8301 8305; }
# Tarp spirals (the four slip configurations' scenarios, two runs each, and
# as many again held out) on which the window protocol was compared between
# the first release and today (docs/fitting.md, the window length). Nothing
# published is fitted, tuned or scored on them.
window_protocol_seeds() { seq 8501 8516; }
# Scored logs.
paper_eval_seeds() { seq 5001 $((5000 + ${1:-20})); }
tuning_eval_seeds() { seq 8001 $((8000 + ${1:-20})); }

# check_disjoint "<scored seeds>" "<seeds used to build>..." : exits 1 naming a shared seed.
check_disjoint() {
  local scored=$1
  shift
  local used
  used=$(printf '%s\n' "$@" | tr ' ' '\n' | sort -u)
  local shared
  shared=$(comm -12 <(printf '%s\n' $scored | sort -u) <(printf '%s\n' $used))
  if [ -n "$shared" ]; then
    echo "seeds used both to build and to score: $(echo $shared | tr '\n' ' ')" >&2
    exit 1
  fi
}
