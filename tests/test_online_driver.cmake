# pgem-online-driver end to end on small graphs written here: the stream's order (each pose
# followed by the edges it completes, file order within a pose, whatever order the file lists
# them in), one update per pose or per --every poses, the bridge's placement of new poses
# (--guess anchored against file), an edge-only file, 3D, the time limit, the files written,
# --mode incremental (the core's pgem_update), --live-em (the pass and its adoption), the
# checkpoints and --no-settle, and the refusals (bad options, bad input).
# Run by CTest as: cmake -DPGEM=<pgem-online-driver> -DWORK=<scratch folder> -P test_online_driver.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# driver_lines(<name>): the JSON lines of <name>_out as the list <name>_lines, and the last
# one (the summary) as <name>_summary.
macro(driver_lines name)
  string(REGEX MATCHALL "{[^\n]*}" ${name}_lines "${${name}_out}")
  list(GET ${name}_lines -1 ${name}_summary)
  nested("${${name}_summary}" summary type)
endmacro()

# update_is(<name> <index> key value ...): the index-th update line (0-based) has these values.
function(update_is name index)
  list(GET ${name}_lines ${index} line)
  nested("${line}" update type)
  expect("${line}" ${ARGN})
endfunction()

# A unit square walked anticlockwise, back to its start: odometry (1, 0, pi/2) every step, and
# two loop closures, consistent with it. The file lists the loop 3 -> 0 first and 4 -> 1 last,
# and starts from a drifting guess.
set(info "100 0 0 100 0 400")
set(step "1 0 1.5707963267948966")
set(edges
  "EDGE_SE2 3 0 ${step} ${info}\n"
  "EDGE_SE2 0 1 ${step} ${info}\n"
  "EDGE_SE2 1 2 ${step} ${info}\n"
  "EDGE_SE2 2 3 ${step} ${info}\n"
  "EDGE_SE2 3 4 ${step} ${info}\n"
  "EDGE_SE2 4 1 ${step} ${info}\n")
file(WRITE "${WORK}/square.g2o"
  "VERTEX_SE2 0 0 0 0\n"
  "VERTEX_SE2 1 1.1 0.05 1.5\n"
  "VERTEX_SE2 2 1.05 1.1 3.0\n"
  "VERTEX_SE2 3 0.1 1.05 -1.6\n"
  "VERTEX_SE2 4 50 50 2\n"
  ${edges})

# ---- one update per pose: the stream's order -------------------------------------------------
pgem_ok(each square.g2o -o each.g2o --weights each.txt --quiet)
driver_lines(each)
list(LENGTH each_lines n)
if(NOT n EQUAL 5)
  fail("each: ${n} lines instead of 4 updates and the summary:\n${each_out}")
endif()
update_is(each 0 update 1 pose 1 id 1 poses 2 edges 1 added 1 loops_added 0 status PGEM_OK)
update_is(each 1 update 2 pose 2 id 2 poses 3 edges 2 added 1 loops_added 0)
update_is(each 2 update 3 pose 3 id 3 poses 4 edges 4 added 2 loops_added 1 loops 1)
update_is(each 3 update 4 pose 4 id 4 poses 5 edges 6 added 2 loops_added 1 loops 2 pruned 0)
expect("${each_summary}" mode full every 1 guess anchored poses 5 poses_total 5 edges 6
       edges_total 6 updates 4 failed_updates 0 restarts 0 stopped OFF status PGEM_OK
       outcome loops_accepted loops 2 pruned 0)
tiny("${each_summary}" final_chi2)
# Placed by the odometry from the solved pose 3, pose 4 starts at its optimum, not at (50, 50).
list(GET each_lines 3 last)
tiny("${last}" initial_chi2)
file(READ "${WORK}/each.txt" weights)
contains(weights "${weights}" "3 0 1 accepted\n4 1 1 accepted\n")
file(READ "${WORK}/each.g2o" written)
contains(written "${written}" "EDGE_SE2 4 1 ")
string(REGEX MATCH "VERTEX_SE2 4 ([^ ]+) ([^ ]+) " pose4 "${written}")
foreach(value "${CMAKE_MATCH_1}" "${CMAKE_MATCH_2}")
  if(NOT (value GREATER -1e-6 AND value LESS 1e-6))
    fail("each: pose 4 should be back at the origin: ${pose4}")
  endif()
endforeach()

# ---- the file's guesses as they are: pose 4 starts 70 m away ----------------------------------
pgem_ok(raw square.g2o --guess file --quiet)
driver_lines(raw)
list(GET raw_lines 3 last)
within("${last}" initial_chi2 1e5 1e12)
expect("${raw_summary}" guess file status PGEM_OK)
tiny("${raw_summary}" final_chi2)

# ---- one update per 2 poses, and after the last ---------------------------------------------
pgem_ok(every square.g2o --every 2 --quiet)
driver_lines(every)
update_is(every 0 update 1 pose 1 edges 1 added 1)
update_is(every 1 update 2 pose 3 edges 4 added 3 loops_added 1)
update_is(every 2 update 3 pose 4 edges 6 added 2)
expect("${every_summary}" every 2 updates 3)

# ---- an edge-only file: poses by id, the guess composed along the odometry -------------------
file(WRITE "${WORK}/edges.g2o" ${edges})
pgem_ok(edges edges.g2o --quiet)
driver_lines(edges)
update_is(edges 2 pose 3 id 3 edges 4 added 2)
expect("${edges_summary}" poses 5 updates 4 status PGEM_OK)
tiny("${edges_summary}" final_chi2)

# ---- 3D: a chain of four poses 1 m apart along x, closed by a loop 3 -> 0 ----------------------
set(info3 "100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400")
file(WRITE "${WORK}/line3.g2o"
  "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
  "VERTEX_SE3:QUAT 1 1.1 0.1 0 0 0 0.05 0.99875\n"
  "VERTEX_SE3:QUAT 2 2.2 0.1 0.1 0 0 0 1\n"
  "VERTEX_SE3:QUAT 3 9 9 9 0 0 0 1\n"
  "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 ${info3}\n"
  "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1 ${info3}\n"
  "EDGE_SE3:QUAT 2 3 1 0 0 0 0 0 1 ${info3}\n"
  "EDGE_SE3:QUAT 3 0 -3 0 0 0 0 0 1 ${info3}\n")
pgem_ok(line3 line3.g2o --quiet)
driver_lines(line3)
update_is(line3 2 pose 3 edges 4 added 2 loops_added 1)
list(GET line3_lines 2 last)
within("${last}" initial_chi2 -1 1e-6)
expect("${line3_summary}" updates 3 loops 1 status PGEM_OK)
tiny("${line3_summary}" final_chi2)

# ---- the time limit: the stream stops after the first update, cleanly ------------------------
pgem_ok(limit square.g2o --time-limit 1e-9 --quiet -o limit.g2o --weights limit.txt)
driver_lines(limit)
expect("${limit_summary}" stopped ON poses 2 edges 1 updates 1 status PGEM_OK)
if(NOT EXISTS "${WORK}/limit.g2o" OR NOT EXISTS "${WORK}/limit.txt")
  fail("limit: the files were not written")
endif()

# ---- --mode incremental: pgem_update after every pose, the settle solve after the stream ------
pgem_ok(incremental square.g2o --mode incremental --quiet -o incremental.g2o)
driver_lines(incremental)
update_is(incremental 0 pose 1 edges 1 added 1 loops_added 0 rebuilt 1)
update_is(incremental 2 pose 3 edges 4 added 2 loops_added 1 rebuilt 0 loops_accepted 1)
expect("${incremental_summary}" mode incremental updates 4 failed_updates 0 loops 2 pruned 0
       status PGEM_OK)
tiny("${incremental_summary}" final_chi2)
if(NOT EXISTS "${WORK}/incremental.g2o")
  fail("incremental: the file was not written")
endif()

# ---- --live-em 2: a pass every 2 poses, adopted at the next pass point; checkpoints ----------
# Pass points after poses 1 and 3 (0-based): the first pass (poses 0-1) is solved after update 1
# and adopted before update 3, which rebuilds; the second (poses 0-3) is never adopted: no point
# follows. Checkpoint 1 of 2 after pose 2 (ceil(5 / 2) = 3 poses), checkpoint 2 at the end, and
# no settle: the summary and -o are the live map.
file(MAKE_DIRECTORY "${WORK}/live")
pgem_ok(live square.g2o --mode incremental --live-em 2 --no-settle --checkpoints 2
        --checkpoint-dir live --quiet -o live.g2o)
driver_lines(live)
list(LENGTH live_lines n)
if(NOT n EQUAL 10)
  fail("live: ${n} lines instead of 4 updates, 2 passes, 1 adoption, 2 checkpoints and the summary:\n${live_out}")
endif()
list(GET live_lines 1 line)
expect("${line}" type pass pass 1 pose 1 poses 2 edges 1 status PGEM_OK outcome no_loops)
list(GET live_lines 3 line)
expect("${line}" type checkpoint checkpoint 1 of 2 poses 3 edges 2 end OFF)
list(GET live_lines 4 line)
expect("${line}" type adopt pose 3 poses 4 edges 4 pass_poses 2 status PGEM_OK poses_adopted 2
       poses_carried 2 edges_adopted 1 loops_changed 0)
update_is(live 5 update 3 pose 3 rebuilt 1 loops_accepted 1)
list(GET live_lines 6 line)
expect("${line}" type pass pass 2 pose 3 poses 4 edges 4 status PGEM_OK loops 1 pruned 0)
tiny("${line}" final_chi2)
list(GET live_lines 8 line)
expect("${line}" type checkpoint checkpoint 2 of 2 poses 5 edges 6 end ON)
expect("${live_summary}" mode incremental updates 4 settle skipped live_em 2 pending ON passes 2
       passes_failed 0 adopted 1 checkpoints 2 graph_loops 2 graph_pruned 0 status PGEM_OK)
equals("${live_summary}" final_chi2 "")
foreach(file checkpoint_01.g2o checkpoint_01.weights checkpoint_02.g2o checkpoint_02.weights)
  if(NOT EXISTS "${WORK}/live/${file}")
    fail("live: ${file} not written")
  endif()
endforeach()
file(STRINGS "${WORK}/live/checkpoint_01.g2o" vertices REGEX "^VERTEX_SE2")
list(LENGTH vertices n)
if(NOT n EQUAL 3)
  fail("live: checkpoint 1 has ${n} poses instead of 3")
endif()
file(READ "${WORK}/live/checkpoint_02.weights" weights)
contains(live "${weights}" "3 0 1 accepted\n4 1 1 accepted\n")
# --no-pending: the gate as without passes (the same verdicts on this consistent square)
pgem_ok(gate square.g2o --mode incremental --live-em 2 --no-pending --no-settle --quiet)
driver_lines(gate)
expect("${gate_summary}" live_em 2 pending OFF passes 2 adopted 1 graph_loops 2 graph_pruned 0)
file(READ "${WORK}/live/checkpoint_02.g2o" final_checkpoint)
file(READ "${WORK}/live.g2o" final_live)
if(NOT final_checkpoint STREQUAL final_live)
  fail("live: without a settle, -o should be the last checkpoint")
endif()

# ---- refusals ----------------------------------------------------------------------------------
pgem_fails(2 mode "--mode takes full or incremental" square.g2o --mode fast)
pgem_fails(2 every0 "--every needs at least 1 pose" square.g2o --every 0)
pgem_fails(2 guess "--guess takes anchored or file" square.g2o --guess best)
pgem_fails(2 limit0 "--time-limit needs a positive number" square.g2o --time-limit 0)
pgem_fails(2 unknown "unknown option '--fast'" square.g2o --fast)
pgem_fails(2 noinput "no input file" --every 2)
pgem_fails(2 two "more than one input file" square.g2o edges.g2o)
pgem_fails(2 livefull "--live-em needs --mode incremental" square.g2o --live-em 2)
pgem_fails(2 live0 "--live-em needs at least 1 pose" square.g2o --mode incremental --live-em 0)
pgem_fails(2 settlefull "--no-settle needs --mode incremental" square.g2o --no-settle)
pgem_fails(2 pending "--no-pending goes with --live-em" square.g2o --mode incremental --no-pending)
pgem_fails(2 checkdir "--checkpoints and --checkpoint-dir go together" square.g2o --checkpoints 2)
pgem_fails(3 nodir "nothere/checkpoint_01.g2o" square.g2o --checkpoints 2 --checkpoint-dir nothere)
pgem_fails(3 missing "missing.g2o" missing.g2o)
file(WRITE "${WORK}/poses.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n")
pgem_fails(1 noedges "poses.g2o has no edges: nothing to stream" poses.g2o)
file(WRITE "${WORK}/bad.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n")
pgem_fails(1 bad "bad.g2o:3" bad.g2o)
# A factor budget too small for all but the first update: each failure is on stderr, the next
# update restarts from the stream's guesses (as the bridge), and nothing is written.
pgem_fails(1 fill "the last update failed" square.g2o --fill-budget 9 -o fill.g2o)
driver_lines(fill)
expect("${fill_summary}" updates 4 failed_updates 3 restarts 2 status PGEM_ERR_FILL_BUDGET outcome failed)
if(EXISTS "${WORK}/fill.g2o")
  fail("fill: fill.g2o written after a failed last update")
endif()
pgem_ok(help --help)
contains(help "${help_out}" "usage: pgem-online-driver IN")
