# The robust back-end end to end through the command-line tool: false loops injected with
# `pgem corrupt` into a simulated graph and into shared datasets are all found by
# `pgem optimize --robust em` (precision = recall = 1 from `pgem eval`), the map is the clean
# optimum, and the same input gives the same bits.
# Run by CTest as: cmake -DPGEM=<pgem> -DWORK=<folder> [-DDATASETS=<dir>] -P test_cli_robust.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# reference(<tag> <clean graph>): the clean graph's optimum, written to <tag>_ref.g2o.
function(reference tag clean)
  pgem_ok(${tag}_reference optimize "${clean}" -o ${tag}_ref.g2o --quiet)
endfunction()

# all_found(<label> <clean graph> <its reference> <policy> <count>): corrupt, robust solve,
# score against the clean optimum. Every false loop rejected, no true loop rejected, the map
# the clean one.
function(all_found label clean reference policy count)
  pgem_ok(${label}_corrupt corrupt "${clean}" -o ${label}_bad.g2o --policy ${policy}
          --count ${count} --seed 1)
  pgem_ok(${label}_solve optimize ${label}_bad.g2o --robust em -o ${label}_res.g2o
          --weights ${label}_w.txt --quiet)
  pgem_ok(${label}_eval eval ${label}_res.g2o --reference ${reference}
          --outliers ${label}_bad.g2o.outliers --weights ${label}_w.txt --json)
  set(json "${${label}_eval_out}")
  message(STATUS "${label}: ${json}")
  equals("${json}" outliers ${count})
  equals("${json}" false_positives 0)
  equals("${json}" false_negatives 0)
  equals("${json}" true_positives ${count})
  within("${json}" ate_relative -1 1e-6)
endfunction()

# A simulated Manhattan walk (independent of the shared datasets).
pgem_ok(simulate simulate -o sim.g2o --poses 800 --seed 5)
reference(sim sim.g2o)
foreach(policy random local random-grouped local-grouped)
  all_found(sim_${policy} sim.g2o sim_ref.g2o ${policy} 50)
endforeach()

# Determinism: the same corrupted input twice gives byte-identical graphs and weights.
pgem_ok(again optimize sim_random_bad.g2o --robust em -o again.g2o --weights again_w.txt --quiet)
foreach(pair "sim_random_res.g2o;again.g2o" "sim_random_w.txt;again_w.txt")
  list(GET pair 0 first)
  list(GET pair 1 second)
  file(SHA256 "${WORK}/${first}" a)
  file(SHA256 "${WORK}/${second}" b)
  if(NOT a STREQUAL b)
    fail("determinism: ${first} and ${second} differ")
  endif()
endforeach()

# Passes that cycle (issue 36): a straight chain of 40 poses and two loop closures from its
# first pose to its last that disagree by 1.2 m. The chain alone predicts either (the test
# re-admits both), each contradicts the other (the test prunes both), and the passes come back
# to the set they left. The run ends at the cycle and says so in the JSON (termination
# oscillated; a converged run has no termination field) and in the text.
set(chain_text "")
foreach(i RANGE 39)
  string(APPEND chain_text "VERTEX_SE2 ${i} ${i} 0 0\n")
endforeach()
foreach(i RANGE 38)
  math(EXPR next "${i} + 1")
  string(APPEND chain_text "EDGE_SE2 ${i} ${next} 1 0 0 400 0 0 400 0 10000\n")
endforeach()
string(APPEND chain_text "EDGE_SE2 0 39 39.6 0 0 100 0 0 100 0 1000\nEDGE_SE2 0 39 38.4 0 0 100 0 0 100 0 1000\n")
file(WRITE "${WORK}/conflict.g2o" "${chain_text}")
pgem_ok(cycle optimize conflict.g2o --robust em --json)
expect("${cycle_out}" status PGEM_OK termination oscillated readmitted 2 gated 2)
within("${cycle_out}" rounds 0 5)
pgem_ok(cycle_text optimize conflict.g2o --robust em --quiet)
contains(cycle_text "${cycle_text_out}" "  not settled: the accepted loop closures came back to a set of an earlier pass")
pgem_ok(settled optimize sim_local_bad.g2o --robust em --json)
string(JSON settled_termination ERROR_VARIABLE missing GET "${settled_out}" termination)
if(NOT missing)
  fail("a converged run reports a termination: ${settled_out}")
endif()

# Shared datasets (skipped with a note when the folder is not beside the repository).
if(DATASETS AND EXISTS "${DATASETS}/2d/intel.g2o" AND EXISTS "${DATASETS}/2d/input_M3500_g2o.g2o")
  set(intel "${DATASETS}/2d/intel.g2o")
  set(m3500 "${DATASETS}/2d/input_M3500_g2o.g2o")
  reference(intel "${intel}")
  foreach(policy random local random-grouped local-grouped)
    all_found(intel_${policy} "${intel}" intel_ref.g2o ${policy} 100)
  endforeach()
  reference(m3500 "${m3500}")
  all_found(m3500_random "${m3500}" m3500_ref.g2o random 100)
  all_found(m3500_grouped "${m3500}" m3500_ref.g2o local-grouped 100)
else()
  message(STATUS "shared datasets not found (DATASETS='${DATASETS}'): dataset cells skipped")
endif()

# corrupt --information: the false loops carry the given matrix; a bad one is refused before
# anything is written.
pgem_ok(information corrupt sim.g2o -o info.g2o --policy random --count 2 --seed 3
        --information 1,0,0,2,0,3)
file(STRINGS "${WORK}/info.g2o" edges REGEX "^EDGE_SE2")
list(GET edges -1 last)
string(REGEX MATCH " 1 0 0 2 0 3$" tail "${last}")
if(NOT tail)
  fail("--information: last edge is '${last}'")
endif()
pgem_fails(2 refused "not positive definite" corrupt sim.g2o -o refused.g2o --policy random
           --count 2 --seed 3 --information 1,5,0,2,0,3)
if(EXISTS "${WORK}/refused.g2o" OR EXISTS "${WORK}/refused.g2o.outliers")
  fail("--information not positive definite: files were written")
endif()

# corrupt --shift: an attacker's group measures the input's relative poses with the second
# stretch moved by one rigid shift, so with a zero shift its loops fit the input's estimates
# exactly and the chi2 there is the clean graph's; a shift of the wrong size is refused.
pgem_ok(ref_chi2 optimize sim_ref.g2o --max-iterations 0 --json --quiet)
json_value("${ref_chi2_out}" initial_chi2 clean_chi2)
pgem_ok(shift_zero corrupt sim_ref.g2o -o shift0.g2o --policy random-grouped --count 20
        --group-size 20 --seed 2 --shift 0,0,0)
pgem_ok(shift_chi2 optimize shift0.g2o --max-iterations 0 --json --quiet)
equals("${shift_chi2_out}" initial_chi2 "${clean_chi2}") # as printed, 10 digits
pgem_ok(shift_some corrupt sim_ref.g2o -o shift1.g2o --policy random-grouped --count 20
        --group-size 20 --seed 2 --shift 5,5,1)
pgem_ok(shift_some_chi2 optimize shift1.g2o --max-iterations 0 --json --quiet)
json_value("${shift_some_chi2_out}" initial_chi2 shifted_chi2)
if(NOT shifted_chi2 GREATER clean_chi2)
  fail("--shift 5,5,1: chi2 ${shifted_chi2} not above the clean ${clean_chi2}")
endif()
pgem_fails(2 shift_size "--shift '1,2': 2 numbers; a 2D graph takes 3" corrupt sim.g2o
           -o never.g2o --policy random-grouped --count 1 --seed 1 --shift 1,2)

# corrupt: an unreadable input is exit 3 (as in every verb); a group of 0 is refused with a
# message; a graph too small for false loops leaves no files behind.
pgem_fails(3 unreadable "cannot open" corrupt missing.g2o -o never.g2o --policy random
           --count 1 --seed 1)
pgem_fails(2 empty_group "--group-size needs at least 1 loop, got 0" corrupt sim.g2o -o never.g2o
           --policy random-grouped --count 1 --group-size 0 --seed 1)
file(WRITE "${WORK}/tiny.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n")
pgem_fails(1 tiny "too few poses" corrupt tiny.g2o -o never.g2o --policy random --count 1 --seed 1)
if(EXISTS "${WORK}/never.g2o" OR EXISTS "${WORK}/never.g2o.outliers")
  fail("corrupt: a refused run wrote files")
endif()

# optimize: --weights without --robust lists every loop (weight 1, accepted); --max-iterations
# limits the robust solve's final solve too.
pgem_ok(plain_weights optimize sim.g2o --weights plain_w.txt --quiet)
file(STRINGS "${WORK}/plain_w.txt" plain_lines REGEX " 1 accepted$")
list(LENGTH plain_lines plain_count)
if(plain_count EQUAL 0)
  fail("optimize --weights without --robust: no loop lines written")
endif()
pgem_ok(limited optimize sim_random_bad.g2o --robust em --max-iterations 1 --json --quiet)
pgem_ok(unlimited optimize sim_random_bad.g2o --robust em --json --quiet)
json_value("${limited_out}" gn_iterations limited_iterations)
json_value("${unlimited_out}" gn_iterations unlimited_iterations)
block_adds_up(unlimited "${unlimited_out}")
if(NOT limited_iterations LESS unlimited_iterations)
  fail("--max-iterations ignored by --robust em: ${limited_iterations} vs ${unlimited_iterations}")
endif()

# Issue 16: a graph whose loop closures are all false says so: the outcome, a warning on
# stderr (also with --json), the chi2 with the rejected loops beside the one without them.
file(STRINGS "${WORK}/sim.g2o" sim_lines)
set(odometry_only "")
foreach(line IN LISTS sim_lines)
  if(line MATCHES "^EDGE_SE2 ([0-9]+) ([0-9]+) ")
    math(EXPR gap "${CMAKE_MATCH_2} - ${CMAKE_MATCH_1}")
    if(NOT (gap EQUAL 1 OR gap EQUAL -1))
      continue()
    endif()
  endif()
  string(APPEND odometry_only "${line}\n")
endforeach()
file(WRITE "${WORK}/chain.g2o" "${odometry_only}")
pgem_ok(chain_corrupt corrupt chain.g2o -o chain_bad.g2o --policy random --count 30 --seed 4)
pgem_ok(all_rejected optimize chain_bad.g2o --robust em --json --quiet)
expect("${all_rejected_out}" outcome all_rejected rejected 30 loops 30 usable ON)
contains(all_rejected "${all_rejected_err}" "warning: all 30 loop closures were rejected: the result is the odometry alone")
json_value("${all_rejected_out}" final_chi2 without)
json_value("${all_rejected_out}" final_chi2_with_rejected with)
if(NOT with GREATER 1000 OR without GREATER 1)
  fail("all rejected: final chi2 ${without}, with the rejected loops ${with}")
endif()
pgem_ok(all_rejected_text optimize chain_bad.g2o --robust em --quiet)
contains(all_rejected_text "${all_rejected_text_out}" "30 of 30 loop closures rejected")
contains(all_rejected_text "${all_rejected_text_out}" "with the rejected loops")
pgem_ok(accepted optimize sim_random_bad.g2o --robust em --json --quiet)
expect("${accepted_out}" outcome loops_accepted)
if(accepted_err MATCHES "warning")
  fail("a graph with its loops accepted warned: ${accepted_err}")
endif()

# Dormant loops change the time, not the answer: the same weights file and graph, to the
# printed digits, with --dormant-threshold off; and --distance point is the paper's method.
pgem_ok(dormant optimize sim_random-grouped_bad.g2o --robust em -o dormant.g2o --weights dormant_w.txt --quiet)
pgem_ok(exact optimize sim_random-grouped_bad.g2o --robust em --dormant-threshold off -o exact.g2o --weights exact_w.txt --quiet)
file(STRINGS "${WORK}/dormant_w.txt" dormant_states REGEX "(accepted|pruned)$")
file(STRINGS "${WORK}/exact_w.txt" exact_states REGEX "(accepted|pruned)$")
string(REGEX REPLACE " [^ ]+ (accepted|pruned)" " \\1" dormant_states "${dormant_states}")
string(REGEX REPLACE " [^ ]+ (accepted|pruned)" " \\1" exact_states "${exact_states}")
if(NOT dormant_states STREQUAL exact_states)
  fail("--dormant-threshold off changed which loops are pruned")
endif()
pgem_ok(point optimize sim_random_bad.g2o --robust em --distance point --json --quiet)
expect("${point_out}" outcome loops_accepted)
pgem_fails(2 bad_distance "--distance takes innovation or point" optimize sim.g2o --robust em --distance other)

# Real loop closures (KITTI 09, DLoopDetector at alpha 1: 2 true loops among 14, a 14.7 m
# odometry drift): both true loops kept, every false one rejected, the map within 3.5 m of the
# ground truth (the paper's point distance prunes all 14 and returns the odometry).
if(DATASETS AND EXISTS "${DATASETS}/real/kitti/kitti_09_alpha_1.00.g2o")
  set(kitti "${DATASETS}/real/kitti/kitti_09")
  file(STRINGS "${kitti}_alpha_1.00_GT_LC.txt" true_pairs REGEX "^[0-9]+ [0-9]+")
  file(STRINGS "${kitti}_alpha_1.00.g2o" kitti_edges REGEX "^EDGE_SE2")
  set(false_pairs "")
  foreach(line IN LISTS kitti_edges)
    string(REGEX MATCH "^EDGE_SE2 +([0-9]+) +([0-9]+)" pair "${line}")
    set(pair_text "${CMAKE_MATCH_1} ${CMAKE_MATCH_2}")
    math(EXPR gap "${CMAKE_MATCH_2} - ${CMAKE_MATCH_1}")
    list(FIND true_pairs "${pair_text}" true_at)
    if(NOT (gap EQUAL 1 OR gap EQUAL -1) AND true_at EQUAL -1)
      string(APPEND false_pairs "${pair_text}\n")
    endif()
  endforeach()
  file(WRITE "${WORK}/kitti.outliers" "${false_pairs}")
  pgem_ok(kitti_solve optimize "${kitti}_alpha_1.00.g2o" --robust em -o kitti_res.g2o --weights kitti_w.txt --quiet)
  pgem_ok(kitti_eval eval kitti_res.g2o --reference "${kitti}_GT.g2o" --outliers kitti.outliers --weights kitti_w.txt --json)
  expect("${kitti_eval_out}" loops 14 outliers 12 true_positives 12 false_positives 0 false_negatives 0)
  within("${kitti_eval_out}" ate_translation_rmse 0 3.5)
else()
  message(STATUS "real datasets not found (DATASETS='${DATASETS}'): the KITTI cell skipped")
endif()
