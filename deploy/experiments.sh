#!/usr/bin/env bash
# Reproduces the README's experiments (docs/method.md §10) from a fresh Debian 12
# machine (as root): builds, starts oaipp-server on loopback, runs
# `oaipp-client eval` for E1-E5 and one E1 mission with its image sequence,
# then stops the server. Results go to out/eval/<experiment> and out/e1.
#   bash deploy/experiments.sh                  # E3 at 10 trials per cell
#   E3_TRIALS=100 bash deploy/experiments.sh    # the paper's 100 per cell
#   EXPERIMENTS="E1 E5" bash deploy/experiments.sh
# E5-settings flies E5 once per file in client/scenarios/e5-settings (e5.json
# with one or two settings changed) to out/eval/E5-<file>; the team4-* files
# there are E7's.
# confirmation flies E1, E4, E5 and E5 under a 12 m ceiling with the extra
# variant oaipp_confirm (the confirmation objective at CONFIRMATION_WEIGHT,
# default 100) to out/eval/confirmation-<experiment>.
# confirmation-phase adds the confirmation phase over the last 45 s to that
# variant: E1 and E4, and E5 under a 12 m ceiling with N = 4 at 50 trials,
# with and without the phase (out/eval/confirmation-phase-<experiment>).
# detector-noise flies every variant with the noise of the scenario's
# detector (--detector_noise) and oaipp_confirm with the phase, at
# confirmation weights 100 and 1000: E1 and E4, E5 under a 12 m ceiling
# with N = 4 and E5 with the paper's settings at 100 trials; at weight 1000
# also E5 under the ceiling on seeds 101-200, and E5 with the paper's
# settings and the phase's weight 30000 (oaipp_confirm only)
# (out/eval/detector-noise-w<weight>-<experiment>).
# false-positives adds the detector's false-positive rate
# (--detector_false_positives) at weight 1000 with the phase: E1 and E4
# (oaipp and oaipp_confirm), E5 under the 12 m ceiling with N = 4 on seeds
# 1-200 (oaipp_confirm) (out/eval/false-positives-<experiment>); then the
# same with a second look in the phase (--second_look_weight=1000,
# oaipp_confirm only; out/eval/false-positives-second-look-<experiment>).
# second-look flies E5 with those options and the second look on fresh
# seeds 201-400 at weights 1000 and 3000, on seeds 201-300 at 10000 and
# with a 60 s phase, with the paper's flight settings at 1000, and E1 and
# E4 at 3000 (out/eval/second-look[-<weight>|-phase60]-<experiment>, as
# in client/results/false-positives/).
# sharp-second-look flies the same options with the sharper second look
# (--second_look_weight=11440 --second_look_sharpness=0.31): E5 under the
# ceiling on fresh seeds 201-400 and on seeds 1-200, E5 with the paper's
# flight settings on seeds 1-200 (oaipp_confirm only), E1 and E4 with
# oaipp beside it, and E5 under the ceiling on seeds 401-600
# (out/eval/sharp-second-look-<experiment>[-seeds<first>-<last>]).
# sharp-second-look-phase60 flies the same with a 60 s phase: E5 with the
# paper's flight settings on seeds 1-400, E5 under the ceiling on seeds
# 401-600 (oaipp_confirm only), and E1 and E4
# (out/eval/sharp-second-look-phase60-<experiment>[-seeds<first>-<last>]).
# sharp-second-look-paper flies E5 with the paper's flight settings and the
# sharp-second-look options (oaipp_confirm only) on fresh seeds 201-300 and
# 301-400, and on seeds 1-100 with the phase's weight raised to 30000 and
# 100000 (out/eval/sharp-second-look-paper-seeds<first>-<last>[-w<weight>]).
# replan-on-detection flies the sharp-second-look options (45 s phase,
# oaipp_confirm only) with the client replanning as soon as the detector
# reports anything (--replan_on_detection): E5 with the paper's flight
# settings and under the 12 m ceiling with N = 4, each on seeds 1-400, and
# E1 and E4
# (out/eval/replan-on-detection-<experiment>[-seeds<first>-<last>]).
# Not in the default list (hours on two cores): E6 flies OA-IPP, lawnmower
# and random on the 300 x 300 m field of client/scenarios/e6.json
# (E6_TRIALS each, default 10); E6-confirm flies them with the detector's
# noise, OA-IPP with the confirmation options (E6_TRIALS, default 5, 30 min);
# PRIOR (not in the default list) flies prior-demo.json's search from a
# lost-person map with the adaptive and detection objectives and the two
# baselines, with the detector's noise (out/eval/PRIOR).
# E6-km2 flies one OA-IPP mission over the
# 1 km^2 field of e6-km2.json at 2 m (250,000 cells) to out/e6-km2.
# E7 flies teams of 1, 2, 4 and 8 UAVs in E5's world, coordinated and the
# two baselines (docs/experiments.md), at E7_BUDGET_S seconds of flight
# (default: the scenarios' 150). Not in the default list: E7-e6 flies one
# UAV and a team of 4 (the three variants) on E6's 300 x 300 m field
# (E7_E6_TRIALS each, default 4, 300 s of flight: 45 min on two cores);
# E7-launch flies the three team variants of four UAVs launched together
# (e5-settings/team4-launch.json, 50 trials, 14 min), the same with 1 m of
# separation (team4-launch-sep1.json, two variants, 50, 10 min), with the
# confirmation term (team4-launch-confirm.json, 25, 12 min) and with that
# term seen from the map's belief now (team4-launch-preposterior.json, 50,
# 22 min); E7-sigma35 flies them with the detector's noise and the altitude
# reward's width halved (team4-launch-sigma35.json, 50, 27 min), where the
# coordinated team is the fastest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
address="127.0.0.1:${OAIPP_PORT:-50051}"
trials="${TRIALS:-25}"
e3_trials="${E3_TRIALS:-10}"
experiments="${EXPERIMENTS:-E1 E2 E3 E4 E5 E5-settings confirmation confirmation-phase detector-noise false-positives second-look sharp-second-look sharp-second-look-phase60 sharp-second-look-paper replan-on-detection}"

label=experiments
source "$root/deploy/serve.sh"
client=("$build/client/oaipp-client" --server="$address")
# The options of the sharp-second-look cases, but for the phase's length.
sharp_look=(--detector_noise --detector_false_positives --confirmation_weight=1000
  --second_look_weight=11440 --second_look_sharpness=0.31)
# E5 with those options, oaipp_confirm only: the phase's length (s), first
# trial, trials, output name under out/eval, more flags.
sharp_e5() {
  "${client[@]}" eval E5 --first_trial="$2" --trials="$3" "${sharp_look[@]}" \
    --confirmation_phase_s="$1" --variants=oaipp_confirm --out="out/eval/$4" "${@:5}"
}
for e in $experiments; do
  echo "== $e"
  case "$e" in
    E2) "${client[@]}" eval E2 --trials="$trials" --plan_budget_s=3 ;;  # the trace objective is slow
    E3) "${client[@]}" eval E3 --trials="$e3_trials" ;;
    PRIOR) "${client[@]}" eval PRIOR --trials="$trials" --detector_noise ;;
    E5-settings)
      for f in client/scenarios/e5-settings/*.json; do
        case "$(basename "$f")" in team4-*) continue ;; esac  # E7's team scenarios
        echo "== E5 with $(basename "$f")"
        "${client[@]}" eval E5 --trials="$trials" --scenario="$f" --out="out/eval/E5-$(basename "$f" .json)"
      done ;;
    confirmation)
      weight="--confirmation_weight=${CONFIRMATION_WEIGHT:-100}"
      for x in E1 E4 E5; do
        "${client[@]}" eval "$x" --trials="$trials" "$weight" --out="out/eval/confirmation-$x"
      done
      "${client[@]}" eval E5 --trials="$trials" "$weight" \
        --scenario=client/scenarios/e5-settings/ceiling12.json --out=out/eval/confirmation-E5-ceiling12 ;;
    confirmation-phase)
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" --confirmation_weight=100 \
          --confirmation_phase_s=45 --out="out/eval/confirmation-phase-$x"
      done
      for phase in 0 45; do
        "${client[@]}" eval E5 --trials=50 --confirmation_weight=100 --confirmation_phase_s="$phase" \
          --scenario=client/scenarios/e5-settings/ceiling12-n4.json \
          --out="out/eval/confirmation-phase-E5-ceiling12-n4-$phase"
      done ;;
    detector-noise)
      for w in 100 1000; do
        confirm=(--detector_noise --confirmation_weight="$w" --confirmation_phase_s=45)
        for x in E1 E4; do
          "${client[@]}" eval "$x" --trials="$trials" "${confirm[@]}" \
            --out="out/eval/detector-noise-w$w-$x"
        done
        "${client[@]}" eval E5 --trials=100 "${confirm[@]}" \
          --scenario=client/scenarios/e5-settings/ceiling12-n4.json \
          --out="out/eval/detector-noise-w$w-E5-ceiling12-n4"
        "${client[@]}" eval E5 --trials=100 "${confirm[@]}" --out="out/eval/detector-noise-w$w-E5"
      done
      "${client[@]}" eval E5 --trials=100 --first_trial=101 --detector_noise \
        --confirmation_weight=1000 --confirmation_phase_s=45 \
        --scenario=client/scenarios/e5-settings/ceiling12-n4.json \
        --out=out/eval/detector-noise-w1000-E5-ceiling12-n4-seeds101-200
      # The phase's weight scaled with the confirmation weight (30 x, as
      # 3000 at 100), on the paper's settings: oaipp_confirm only.
      "${client[@]}" eval E5 --trials=100 --detector_noise --confirmation_weight=1000 \
        --confirmation_phase_s=45 --confirmation_phase_weight=30000 --variants=oaipp_confirm \
        --out=out/eval/detector-noise-w1000-pw30000-E5 ;;
    false-positives)
      # The detector's noise with its false-positive rate (detections and
      # misses weighed by their likelihood ratios), weight 1000, the phase:
      # E1 and E4 with the paper's objective and the confirmation option,
      # E5 under the 12 m ceiling with N = 4 on seeds 1-200.
      confirm=(--detector_noise --detector_false_positives --confirmation_weight=1000
        --confirmation_phase_s=45)
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${confirm[@]}" --variants=oaipp,oaipp_confirm \
          --out="out/eval/false-positives-$x"
      done
      "${client[@]}" eval E5 --trials=200 "${confirm[@]}" --variants=oaipp_confirm \
        --scenario=client/scenarios/e5-settings/ceiling12-n4.json \
        --out=out/eval/false-positives-E5-ceiling12-n4
      # The same with a second look at ground seen once in the phase.
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${confirm[@]}" --second_look_weight=1000 \
          --variants=oaipp_confirm --out="out/eval/false-positives-second-look-$x"
      done
      "${client[@]}" eval E5 --trials=200 "${confirm[@]}" --second_look_weight=1000 \
        --variants=oaipp_confirm --scenario=client/scenarios/e5-settings/ceiling12-n4.json \
        --out=out/eval/false-positives-second-look-E5-ceiling12-n4 ;;
    second-look)
      # The false-positives options with the second look, on fresh seeds
      # and at other weights, a longer phase and the paper's flight
      # settings: oaipp_confirm only, E5 at 100 trials.
      confirm=(--detector_noise --detector_false_positives --confirmation_weight=1000
        --variants=oaipp_confirm)
      ceiling=--scenario=client/scenarios/e5-settings/ceiling12-n4.json
      for first in 201 301; do
        for w in 1000 3000; do
          name=second-look; [[ $w == 1000 ]] || name="second-look-$w"
          "${client[@]}" eval E5 --trials=100 --first_trial="$first" "${confirm[@]}" \
            --confirmation_phase_s=45 --second_look_weight="$w" "$ceiling" \
            --out="out/eval/$name-E5-ceiling12-n4-seeds$first-$((first + 99))"
        done
      done
      "${client[@]}" eval E5 --trials=100 --first_trial=201 "${confirm[@]}" \
        --confirmation_phase_s=45 --second_look_weight=10000 "$ceiling" \
        --out=out/eval/second-look-10000-E5-ceiling12-n4-seeds201-300
      "${client[@]}" eval E5 --trials=100 --first_trial=201 "${confirm[@]}" \
        --confirmation_phase_s=60 --second_look_weight=1000 "$ceiling" \
        --out=out/eval/second-look-phase60-E5-ceiling12-n4-seeds201-300
      "${client[@]}" eval E5 --trials=100 "${confirm[@]}" --confirmation_phase_s=45 \
        --second_look_weight=1000 --out=out/eval/second-look-E5-paper-settings
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${confirm[@]}" --confirmation_phase_s=45 \
          --second_look_weight=3000 --out="out/eval/second-look-3000-$x"
      done ;;
    sharp-second-look)
      ceiling=--scenario=client/scenarios/e5-settings/ceiling12-n4.json
      sharp_e5 45 201 200 sharp-second-look-E5-ceiling12-n4-seeds201-400 "$ceiling"
      sharp_e5 45 1 200 sharp-second-look-E5-ceiling12-n4-seeds1-200 "$ceiling"
      sharp_e5 45 1 100 sharp-second-look-E5-paper-settings
      sharp_e5 45 101 100 sharp-second-look-E5-paper-settings-seeds101-200
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${sharp_look[@]}" --confirmation_phase_s=45 \
          --variants=oaipp,oaipp_confirm --out="out/eval/sharp-second-look-$x"
      done
      sharp_e5 45 401 200 sharp-second-look-E5-ceiling12-n4-seeds401-600 "$ceiling" ;;
    sharp-second-look-phase60)
      for first in 1 201; do
        sharp_e5 60 "$first" 200 \
          "sharp-second-look-phase60-E5-paper-settings-seeds$first-$((first + 199))"
      done
      sharp_e5 60 401 200 sharp-second-look-phase60-E5-ceiling12-n4-seeds401-600 \
        --scenario=client/scenarios/e5-settings/ceiling12-n4.json
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${sharp_look[@]}" --confirmation_phase_s=60 \
          --variants=oaipp_confirm --out="out/eval/sharp-second-look-phase60-$x"
      done ;;
    sharp-second-look-paper)
      for first in 201 301; do
        sharp_e5 45 "$first" 100 "sharp-second-look-paper-seeds$first-$((first + 99))"
      done
      for w in 30000 100000; do
        sharp_e5 45 1 100 "sharp-second-look-paper-seeds1-100-w$w" --confirmation_phase_weight="$w"
      done ;;
    replan-on-detection)
      for first in 1 101 201 301; do
        sharp_e5 45 "$first" 100 "replan-on-detection-E5-paper-seeds$first-$((first + 99))" \
          --replan_on_detection
        sharp_e5 45 "$first" 100 \
          "replan-on-detection-E5-ceiling12-n4-seeds$first-$((first + 99))" --replan_on_detection \
          --scenario=client/scenarios/e5-settings/ceiling12-n4.json
      done
      for x in E1 E4; do
        "${client[@]}" eval "$x" --trials="$trials" "${sharp_look[@]}" --confirmation_phase_s=45 \
          --variants=oaipp_confirm --replan_on_detection --out="out/eval/replan-on-detection-$x"
      done ;;
    E6) "${client[@]}" eval E6 --trials="${E6_TRIALS:-10}" ;;
    E6-confirm)
      # E6 with the detector's noise and false positives for every variant,
      # and OA-IPP with E5's best confirmation options (oaipp_confirm).
      "${client[@]}" eval E6 --trials="${E6_TRIALS:-5}" "${sharp_look[@]}" --confirmation_phase_s=45 \
        --replan_on_detection --variants=oaipp_confirm,lawnmower,random --out=out/eval/E6-confirm ;;
    E6-km2) "${client[@]}" run client/scenarios/e6-km2.json --out=out/e6-km2 ;;
    E7) "${client[@]}" eval E7 --trials="$trials" --e7_budget_s="${E7_BUDGET_S:-0}" ;;
    E7-e6)
      "${client[@]}" eval E7 --trials="${E7_E6_TRIALS:-4}" --scenario=client/scenarios/e6.json \
        --team_scenarios=client/scenarios/e6-team4.json --e7_budget_s="${E7_BUDGET_S:-300}" \
        --out=out/eval/E7-e6 ;;
    E7-launch)
      for run in "team4-launch 50 team4,team4-noshots,team4-alone" \
                 "team4-launch-sep1 50 team4,team4-noshots" \
                 "team4-launch-confirm 25 team4,team4-noshots,team4-alone" \
                 "team4-launch-preposterior 50 team4,team4-noshots,team4-alone"; do
        read -r f n variants <<< "$run"
        "${client[@]}" eval E7 --trials="$n" --team_scenarios="client/scenarios/e5-settings/$f.json" \
          --variants="$variants" --out="out/eval/E7-$f"
      done ;;
    E7-sigma35)
      "${client[@]}" eval E7 --trials=50 --detector_noise --detector_false_positives \
        --team_scenarios=client/scenarios/e5-settings/team4-launch-sigma35.json \
        --variants=team4,team4-noshots,team4-alone --out=out/eval/E7-team4-launch-sigma35 ;;
    *) "${client[@]}" eval "$e" --trials="$trials" ;;
  esac
done
echo "== one E1 mission, with an image per measurement"
"${client[@]}" run client/scenarios/e1.json --out=out/e1 --frames=out/e1/frames
