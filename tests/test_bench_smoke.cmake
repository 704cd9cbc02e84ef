# tools/bench/bench.py end to end, pgem alone (no GTSAM, no numpy): one Gauss-Newton run on
# intel and input_M3500_g2o, one EM run on input_M3500_g2o with 100 random false loops. The
# report must be written and hold the Gauss-Newton, robust and memory tables and the targets.
# Run by CTest as:
#   cmake -DPYTHON=<python3> -DBENCH=<bench.py> -DPGEM=<pgem> -DOUT=<report.md>
#         [-DDATASETS=<dir>] -P test_bench_smoke.cmake
# Prints "bench_smoke: skipped: ..." (which CTest reports as skipped) without the datasets.
include(${CMAKE_CURRENT_LIST_DIR}/bench_report.cmake)
bench_smoke_inputs(bench_smoke 2d/intel.g2o 2d/input_M3500_g2o.g2o)
bench_report(report --quick --peer none --runs 1 --pgem "${PGEM}" --datasets "${DATASETS}"
                    --work "${out_dir}/${out_name}_work")
bench_expect("${report}"
    "## Gauss-Newton on the clean graphs"
    "| dataset | dim | poses | edges | pgem time |"
    "| intel | 2D | 943 | 1837 |"
    "| input_M3500_g2o | 2D | 3500 | 5453 |"
    "## Robust solves on corrupted graphs"
    "| input_M3500_g2o | random | 100 | 1 | pgem-em |"
    "1.000 / 1.000"
    "## Memory"
    "## Timing spread"
    "## Targets"
    "## Failures and timeouts\n\nNone.")
