# pgem stats, end to end: writes small graphs with known defects into WORK and checks the
# counts, the verdict and the exit code; then, when the shared datasets are present, checks
# intel.g2o against counts made here from its lines.
# Run by CTest as: cmake -DPGEM=<pgem> -DWORK=<folder> [-DDATASETS=<dir>] -P test_cli_stats.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# stats(<expected exit code> <name> args...): runs pgem stats; sets <name>_out and <name>_err.
macro(stats expected name)
  pgem_expect(${expected} ${name} stats ${ARGN})
endmacro()

set(I2 "100 0 0 100 0 400")

# ---- clean: a square walk (0..4) closed by one loop; every pose has degree 2 ------------------
file(WRITE "${WORK}/clean.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 1.5707963\nVERTEX_SE2 2 1 1 3.1415926\n"
  "VERTEX_SE2 3 0 1 -1.5707963\nVERTEX_SE2 4 0 0 0\n"
  "EDGE_SE2 0 1 1 0 1.5707963 ${I2}\nEDGE_SE2 1 2 1 0 1.5707963 ${I2}\n"
  "EDGE_SE2 2 3 1 0 1.5707963 ${I2}\nEDGE_SE2 3 4 1 0 1.5707963 ${I2}\n"
  "EDGE_SE2 4 0 0 0 0 ${I2}\n")
stats(0 clean clean.g2o --json)
json_object(clean "${clean_out}")
expect("${clean_out}" verdict ok file clean.g2o dimension 2 poses 5 edges 5 odometry 4 loops 1
       degree_min 2 degree_max 2 degree0 0 degree1 0 loop_leaves 0 components 1
       components_without_fixed 0 duplicate_pairs 0 self_loops 0 information_ok 5
       information_not_pd 0 information_asymmetric 0 angles_out_of_range 0 id_min 0 id_max 4
       id_gaps 0 ids_missing 0 fixed 0 non_finite 0 missing_pose_edges 0)
nested("${clean_out}" 5 component_sizes 0)
nested("${clean_out}" 1 bbox_max 0)
stats(0 clean_text clean.g2o)
contains(clean_text "${clean_text_out}" "verdict      ok")
contains(clean_text "${clean_text_out}" "components   1 (5 poses), held by the first pose")

# ---- an open chain: its two ends have degree 1 on odometry, which is fine ---------------------
file(WRITE "${WORK}/chain.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 4\n"
  "EDGE_SE2 0 1 1 0 0 ${I2}\nEDGE_SE2 2 1 -1 0 0 ${I2}\n")
stats(0 chain chain.g2o --json)
expect("${chain_out}" verdict ok degree1 2 loop_leaves 0 odometry 2 loops 0 angles_out_of_range 1)

# ---- warnings: 1-2 measured twice (once backwards: the second edge between 1 and 2 is a loop
# closure), pose 9 held only by the loop 2 -> 9 -------------------------------------------------
file(WRITE "${WORK}/warn.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SE2 3 3 0 0\n"
  "VERTEX_SE2 9 2 5 0\n"
  "EDGE_SE2 0 1 1 0 0 ${I2}\nEDGE_SE2 1 2 1 0 0 ${I2}\nEDGE_SE2 2 3 1 0 0 ${I2}\n"
  "EDGE_SE2 3 0 -3 0 0 ${I2}\nEDGE_SE2 2 1 -1.01 0 0 ${I2}\nEDGE_SE2 2 9 0 5 0 ${I2}\n")
stats(0 warn warn.g2o --json)
expect("${warn_out}" verdict warnings poses 5 edges 6 odometry 3 loops 3 duplicate_pairs 1
       duplicate_edges 1 duplicate_exact 0 degree1 1 loop_leaves 1 degree_min 1 degree_max 4
       components 1 id_gaps 1 ids_missing 5 information_ok 6)
nested("${warn_out}" 7 duplicate_pairs_first 0 line)
nested("${warn_out}" 10 duplicate_pairs_first 0 second_line)
nested("${warn_out}" 9 loop_leaves_first 0 pose)
nested("${warn_out}" 11 loop_leaves_first 0 line)
length("${warn_out}" 2 reasons)
stats(0 warn_text warn.g2o)
contains(warn_text "${warn_text_out}"
         "verdict      warnings: 1 duplicated pair; 1 pose held only by a loop closure")
contains(warn_text "${warn_text_out}" "1 - 2: 2 edges, lines 7, 10")

# ---- problems: two components, the second (5, 6) without a fixed pose -------------------------
file(WRITE "${WORK}/split.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
  "VERTEX_SE2 5 0 3 0\nVERTEX_SE2 6 1 3 0\n"
  "EDGE_SE2 0 1 1 0 0 ${I2}\nEDGE_SE2 1 2 1 0 0 ${I2}\nEDGE_SE2 2 0 -2 0 0 ${I2}\n"
  "EDGE_SE2 5 6 1 0 0 ${I2}\nEDGE_SE2 6 5 -1 0 0 ${I2}\n")
stats(1 split split.g2o --json)
expect("${split_out}" verdict problems components 2 components_without_fixed 1 duplicate_pairs 1
       degree_min 2 fixed 0)
nested("${split_out}" 3 component_sizes 0)
nested("${split_out}" 2 component_sizes 1)
stats(1 split_text split.g2o)
contains(split_text "${split_text_out}" "e.g. the part with pose 5: FIX a pose in each part")
# A FIX line in each part makes it solvable (the duplicated pair stays a warning).
file(READ "${WORK}/split.g2o" split)
file(WRITE "${WORK}/split_fixed.g2o" "${split}FIX 0 6\n")
stats(0 split_fixed split_fixed.g2o --json)
expect("${split_fixed_out}" verdict warnings components 2 components_without_fixed 0 fixed 2)
# FIX in one part only: the first pose is no longer the gauge, so the other part floats.
file(WRITE "${WORK}/split_one.g2o" "${split}FIX 6\n")
stats(1 split_one split_one.g2o --json)
expect("${split_one_out}" verdict problems components_without_fixed 1)

# ---- problems: information not positive definite (the reader keeps it), and a self-loop -------
file(WRITE "${WORK}/bad.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
  "EDGE_SE2 0 1 1 0 0 ${I2}\n"
  "EDGE_SE2 1 2 1 0 0 1 2 0 1 0 1\n"
  "EDGE_SE2 2 0 -2 0 0 100 0 0 100 0 0\n"
  "EDGE_SE2 2 2 0 0 0 ${I2}\n")
stats(1 bad bad.g2o --json)
expect("${bad_out}" verdict problems edges 3 information_ok 1 information_not_pd 2
       information_asymmetric 0 self_loops 1 components 1 degree_min 2)
nested("${bad_out}" 5 information_not_pd_first 0 line)
nested("${bad_out}" 6 information_not_pd_first 1 line)
nested("${bad_out}" 7 self_loops_first 0 line)
nested("${bad_out}" 2 self_loops_first 0 from)
# a self-loop alone is a warning: the reader leaves it out and the graph solves
file(WRITE "${WORK}/self.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 ${I2}\nEDGE_SE2 1 1 0 0 0 ${I2}\n")
stats(0 self self.g2o --json)
expect("${self_out}" verdict warnings edges 1 self_loops 1)
nested("${self_out}" 4 self_loops_first 0 line)
stats(0 self_text self.g2o)
contains(self_text "${self_text_out}" "1 self-loop edge skipped")

# ---- 3D: quaternions slightly off (a note), off by 0.2% (a warning), off by 5% (a problem) ----
set(I3 "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 4 0 0 4 0 4")
set(rotations3 "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1.000002\n"
  "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 ${I3}\n")
file(WRITE "${WORK}/note3.g2o" ${rotations3})
stats(0 note3 note3.g2o --json)
expect("${note3_out}" verdict ok dimension 3 quaternions_off 1 quaternions_refused 0)
length("${note3_out}" 1 notes)
file(WRITE "${WORK}/warn3.g2o" ${rotations3} "VERTEX_SE3:QUAT 2 2 0 0 0 0 0 1.002\n"
  "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1 ${I3}\n")
stats(0 warn3 warn3.g2o --json)
expect("${warn3_out}" verdict warnings quaternions_off 2 quaternions_refused 0)
file(WRITE "${WORK}/bad3.g2o" ${rotations3} "VERTEX_SE3:QUAT 2 2 0 0 0 0 0 1.05\n"
  "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1 ${I3}\n")
stats(1 bad3 bad3.g2o --json)
expect("${bad3_out}" verdict problems quaternions_refused 1)
nested("${bad3_out}" 4 quaternions_refused_first 0 line)
nested("${bad3_out}" 2 quaternions_refused_first 0 pose)

# ---- files the reader refuses or cannot open; empty files; the command line --------------------
file(WRITE "${WORK}/nan.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 nan 0 0\n")
pgem_fails(1 nan "pgem stats: nan.g2o:2:" stats nan.g2o)
stats(3 absent absent.g2o)
file(WRITE "${WORK}/empty.g2o" "# nothing\nVERTEX3 0 0 0 0 0 0 0\n")
stats(1 empty empty.g2o --json)
expect("${empty_out}" verdict problems poses 0 unknown_lines 1 dimension 0)
stats(2 no_args)
stats(2 two_files clean.g2o chain.g2o)
stats(2 bad_option clean.g2o --verbose)
stats(0 help --help)
contains(help "${help_out}" "usage: pgem stats GRAPH [--json]")

# ---- shared datasets: intel.g2o against counts made from its lines ---------------------------
if(DATASETS AND EXISTS "${DATASETS}/2d/intel.g2o")
  set(intel "${DATASETS}/2d/intel.g2o")
  file(STRINGS "${intel}" vertices REGEX "^VERTEX_SE2 ")
  file(STRINGS "${intel}" edges REGEX "^EDGE_SE2 ")
  list(LENGTH vertices vertex_count)
  list(LENGTH edges edge_count)
  # odometry (|i - j| = 1) and unordered pairs seen more than once, counted here
  set(odometry 0)
  set(pairs "")
  foreach(line IN LISTS edges)
    string(REGEX MATCH "^EDGE_SE2 ([0-9]+) ([0-9]+) " ends "${line}")
    set(a ${CMAKE_MATCH_1})
    set(b ${CMAKE_MATCH_2})
    math(EXPR gap "${a} - ${b}")
    if(gap EQUAL 1 OR gap EQUAL -1)
      math(EXPR odometry "${odometry} + 1")
    endif()
    if(a GREATER b)
      list(APPEND pairs "${b}_${a}")
    else()
      list(APPEND pairs "${a}_${b}")
    endif()
  endforeach()
  list(LENGTH pairs pair_count)
  list(REMOVE_DUPLICATES pairs)
  list(LENGTH pairs distinct)
  math(EXPR extra "${pair_count} - ${distinct}")
  math(EXPR loops "${edge_count} - ${odometry}")
  # The file repeats two loop-closure lines word for word (60 863 and 179 864), so its
  # verdict is warnings (duplicated pairs), not ok; nothing keeps it from optimizing.
  if(extra EQUAL 0)
    set(verdict ok)
  else()
    set(verdict warnings)
  endif()
  stats(0 intel "${intel}" --json)
  message(STATUS "intel.g2o: ${vertex_count} vertices, ${edge_count} edges, ${odometry} odometry, "
                 "${extra} repeated pairs -> ${verdict}")
  expect("${intel_out}" verdict ${verdict} poses ${vertex_count} edges ${edge_count}
         odometry ${odometry} loops ${loops} duplicate_edges ${extra} components 1
         components_without_fixed 0 information_ok ${edge_count} self_loops 0 degree1 0)
else()
  message(STATUS "shared datasets not found (DATASETS='${DATASETS}'): intel.g2o check skipped")
endif()

# ---- what optimize refuses, stats calls problems (issue 17: it said ok) -----------------------
file(WRITE "${WORK}/all_fixed.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 ${I2}\nFIX 0 1\n")
stats(1 all_fixed all_fixed.g2o --json)
expect("${all_fixed_out}" verdict problems)
nested("${all_fixed_out}" "optimize would refuse it: every pose is fixed: nothing to optimize" reasons 0)
pgem_expect(1 all_fixed_optimize optimize all_fixed.g2o)
contains(all_fixed_optimize "${all_fixed_optimize_err}" "every pose is fixed: nothing to optimize")
file(WRITE "${WORK}/one_vertex.g2o" "VERTEX_SE2 0 0 0 0\n")
stats(1 one_vertex one_vertex.g2o)
contains(one_vertex "${one_vertex_out}" "verdict      problems: no edges: nothing to optimize")
pgem_expect(1 one_vertex_optimize optimize one_vertex.g2o)
file(WRITE "${WORK}/far_vertex.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1e308 0 0\nEDGE_SE2 0 1 1 0 0 ${I2}\n")
stats(1 far_vertex far_vertex.g2o)
contains(far_vertex "${far_vertex_err}" "pgem stats: far_vertex.g2o:2: VERTEX_SE2 field 2 (x) is 1e308, beyond the translation limit")
