# tools/bench/bench_real.py end to end, pgem alone (no GTSAM, no numpy): --quick (KITTI 09 at
# alpha 1.00, Vertigo ring, ring with 100 random false loops), run twice: the first run with
# --no-cache computes the three oracles, the second must reuse them. The report must hold the
# summary, the targets and one row per cell and method, with the loops labelled as the datasets
# say and the written initial guess bit-identical to pgem's.
# Run by CTest as:
#   cmake -DPYTHON=<python3> -DBENCH=<bench_real.py> -DPGEM=<pgem> -DOUT=<report.md>
#         [-DDATASETS=<dir>] -P test_bench_real_smoke.cmake
# Prints "bench_real_smoke: skipped: ..." (which CTest reports as skipped) without the datasets.
include(${CMAKE_CURRENT_LIST_DIR}/bench_report.cmake)
bench_smoke_inputs(bench_real_smoke real/kitti/kitti_09_alpha_1.00.g2o real/kitti/kitti_09_alpha_1.00_GT_LC.txt
                   real/kitti/kitti_09_GT.g2o real/vertigo/ring.g2o real/vertigo/ring_groundTruth.g2o)
set(options --quick --peer none --pgem "${PGEM}" --datasets "${DATASETS}" --work "${out_dir}/${out_name}_work")
file(REMOVE_RECURSE "${out_dir}/${out_name}_work")

bench_report(report ${options} --no-cache)
bench_expect("${report}" "Cache: 0 result(s) reused, 3 computed (--no-cache).")
bench_report(report ${options})
bench_expect("${report}"
    "Cache: 3 result(s) reused, 0 computed."
    "## Summary"
    "| cell | truth | odometry ATE | oracle ATE | best method |"
    "| `real/kitti_09_alpha_1.00` | ground truth |"
    "| `real/ring` | ground truth |"
    "| `synth/ring/random/100/s1` | ground truth |"
    "## Targets (pgem-em)"
    "- **P = R = 1**"
    "## Real graphs"
    "| cell | loops true / false | odometry ATE m | method | true rejected | false kept | P | R | F1 |"
    "| `real/kitti_09_alpha_1.00` | 2 / 12 |"
    "| `real/ring` | 26 / 0 |"
    "## Synthetic: ring"
    "| `synth/ring/random/100/s1` | 26 / 100 |"
    "- `real/kitti_09_alpha_1.00`: bit-identical"
    "- `real/ring`: bit-identical"
    "## Failures and timeouts\n\nNone.")
# One row per cell for each pgem method (bold when it is the cell's best).
foreach(method pgem-em pgem-dormant-off pgem-literal)
  bench_count("${report}" "\\|  \\|  \\|  \\| (\\*\\*)?${method}(\\*\\*)? \\| [0-9]+ \\| [0-9]+ \\|" 3)
endforeach()
bench_json_length("${raw}" cells 3)
