# The seeds of every simulated log the project's scripts fit, tune or choose
# defaults on, and of the logs they score; sourced by those scripts, whose
# check_disjoint fails loudly if a scored seed was also used to build what is
# scored. No number in docs/ comes from a log that shaped it.
#   source scripts/seeds.sh

# scripts/fit_bundled_configs.sh: LTC modes 100-102 and STC modes 200-215,
# four maneuvers each (seed * 10 + maneuver), with the ideal sensors; with a
# Husky-class robot's sensors, fitting LTC 110-112 and STC 220-235, tuning
# (estimating R) LTC 120-122 and STC 240-255.
bundled_fit_seeds() {
  local s i
  for s in $(seq 100 102) $(seq 200 215) $(seq 110 112) $(seq 220 235) $(seq 120 122) $(seq 240 255); do
    for i in 0 1 2 3; do echo $((s * 10 + i)); done
  done
}
# scripts/reproduce_tuning.sh: fitting drivers and tuning logs.
tuning_fit_seeds() { seq 7001 7003; seq 7011 7020; }
# The switching logs on which the decision's default settings are weighed
# against others (scripts/reproduce_paper.sh, docs/results.md).
decision_default_seeds() { seq 8101 8120; }
# Spirals (the four slip configurations' scenarios) on which choices about
# stc_traction and its bank were checked while developing it: the skid growth
# per side, and how far the gyro's noise may be trusted. No bank or setting is
# fitted or tuned on them, and none is scored on them.
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
