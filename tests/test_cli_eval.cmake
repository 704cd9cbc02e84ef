# pgem eval, end to end: writes small graphs, weights and outlier lists into WORK, runs the
# tool and checks its numbers against values worked out by hand, and its errors.
# Run by CTest as: cmake -DPGEM=<pgem executable> -DWORK=<scratch folder> -P test_cli_eval.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# eval(<expected exit code> <name> args...): runs pgem eval; sets <name>_out and <name>_err.
macro(eval expected name)
  pgem_expect(${expected} ${name} eval ${ARGN})
endmacro()

# ---- 2D: a copy rotated by 30 degrees about the origin and moved by (5, -3) ---------------
# ref2 has edges (ignored) and a pose (200) the result lacks, between ids 2 and 3 in the
# file, so RPE must pair 2 with 3; the result has a pose (100) the reference lacks.
file(WRITE "${WORK}/ref2.g2o" "# reference\n"
  "VERTEX_SE2 0 0 0 0\n"
  "VERTEX_SE2 1 1.5 0.2 0.3\n"
  "VERTEX_SE2 2 2.7 1.1 1.2\n"
  "VERTEX_SE2 200 -5 -5 0\n"
  "VERTEX_SE2 3 2.0 3.0 2.9\n"
  "VERTEX_SE2 4 0.4 2.2 -2.8\n"
  "VERTEX_SE2 5 -1.0 1.0 -1.0\n"
  "EDGE_SE2 0 1 1.5 0.2 0.3 1 0 0 1 0 1\n"
  "EDGE_SE2 1 4 1 1 1 1 0 0 1 0 1\n")
# (x, y, th) -> (R(30 deg) (x, y) + (5, -3), th + 30 deg); headings left unwrapped.
file(WRITE "${WORK}/rotated2.g2o"
  "VERTEX_SE2 0 5.0 -3.0 0.5235987755982988\n"
  "VERTEX_SE2 1 6.199038105676658 -2.0767949192431123 0.8235987755982987\n"
  "VERTEX_SE2 2 6.788268590217985 -0.6973720558371177 1.7235987755982989\n"
  "VERTEX_SE2 3 5.232050807568878 0.598076211353316 3.4235987755982986\n"
  "VERTEX_SE2 4 4.246410161513776 -0.8947441116742345 -2.276401224401701\n"
  "VERTEX_SE2 5 3.6339745962155616 -2.633974596215561 -0.4764012244017012\n"
  "VERTEX_SE2 100 9 9 0\n")
eval(0 rotated2 rotated2.g2o --reference ref2.g2o --json)
json_object(rotated2 "${rotated2_out}")
equals("${rotated2_out}" result "rotated2.g2o")
equals("${rotated2_out}" reference "ref2.g2o")
equals("${rotated2_out}" dimension 2)
equals("${rotated2_out}" poses_matched 6)
equals("${rotated2_out}" poses_only_result 1)
equals("${rotated2_out}" poses_only_reference 1)
tiny("${rotated2_out}" ate_translation_rmse ate_rotation_rmse_deg rpe_translation_rmse
     rpe_rotation_rmse_deg ate_relative)
string(JSON loops ERROR_VARIABLE no_loops GET "${rotated2_out}" loops)
if(NOT no_loops)
  fail("rotated2: 'loops' printed without --outliers/--weights")
endif()

# ---- 2D: one pose moved by a known amount ------------------------------------------------
# A 2 m square walked anticlockwise (TORO lines); the result moves corner 3, (0, 2), by
# d = (-0.3, 0.3), radially away from the centroid (1, 1), and turns it by 0.1 rad. The
# cross-covariance term d x (corner - centroid) is 0, so the best rotation is the identity
# and the best translation -d/4: errors are 3d/4 at corner 3 and d/4 elsewhere, so
#   ATE = |d| sqrt(3) / 4 = 0.3 sqrt(6) / 4,   ATE rotation = sqrt(0.1^2 / 4) rad = 0.05 rad,
#   RPE (pairs 0-1, 1-2, 2-3; only 2-3 is off, by x3^-1 x3' = (R3^T d, 0.1)):
#       sqrt(|d|^2 / 3) = 0.3 sqrt(2/3) m and 0.1 / sqrt(3) rad,
#   extent = sqrt(2) (every corner is sqrt(2) from the centroid), ate_relative = 0.3 sqrt(3)/4.
file(WRITE "${WORK}/square.txt"
  "VERTEX2 0 0 0 0\n"
  "VERTEX2 1 2 0 1.5707963267948966\n"
  "VERTEX2 2 2 2 3.141592653589793\n"
  "VERTEX2 3 0 2 -1.5707963267948966\n")
file(WRITE "${WORK}/square_moved.g2o"
  "VERTEX_SE2 0 0 0 0\n"
  "VERTEX_SE2 1 2 0 1.5707963267948966\n"
  "VERTEX_SE2 2 2 2 3.141592653589793\n"
  "VERTEX_SE2 3 -0.3 2.3 -1.4707963267948966\n")
eval(0 moved2 square_moved.g2o --reference square.txt --json)
# bounds: the value times (1 -+ 1e-9)
within("${moved2_out}" ate_translation_rmse 0.18371173052502662 0.18371173089245008)  # 0.18371173070873834
within("${moved2_out}" ate_rotation_rmse_deg 2.8647889727893276 2.864788978518906)    # 2.8647889756541165
within("${moved2_out}" rpe_translation_rmse 0.24494897403336885 0.24494897452326683)  # 0.24494897427831783
within("${moved2_out}" rpe_rotation_rmse_deg 3.307973369222779 3.307973375838726)     # 3.3079733725307525
within("${moved2_out}" extent_rms 1.4142135609588817 1.4142135637873088)              # 1.4142135623730951
within("${moved2_out}" ate_relative 0.12990381043776197 0.1299038106975696)           # 0.12990381056766578
eval(0 moved2_text square_moved.g2o --reference square.txt)
contains(moved2_text "${moved2_text_out}" "ATE        0.183712 m RMSE, 2.86479 deg RMS rotation")
contains(moved2_text "${moved2_text_out}" "4 matched, 0 only in the result, 0 only in the reference")

# ---- 3D: a copy rotated by 40 degrees about (1, 2, 3) and moved by (1, -2, 0.5) -----------
file(WRITE "${WORK}/ref3.g2o"
  "VERTEX_SE3:QUAT 0 0.0 0.0 0.0 0.0 0.0 0.0 1.0\n"
  "VERTEX_SE3:QUAT 1 2.0 0.0 0.0 0.0 0.0 0.24740395925452294 0.9689124217106447\n"
  "VERTEX_SE3:QUAT 2 0.0 2.0 0.0 0.33900504942104487 0.33900504942104487 0.0 0.8775825618903728\n"
  "VERTEX_SE3:QUAT 3 0.0 0.0 2.0 0.2248925804330292 -0.4497851608660584 0.6746777412990876 0.5403023058681398\n"
  "VERTEX_SE3:QUAT 4 1.0 1.0 1.0 -0.0 -0.34289780745545134 -0.0 0.9393727128473789\n")
file(WRITE "${WORK}/rotated3.g2o"
  "VERTEX_SE3:QUAT 0 1.0 -2.0 0.5 0.0914087282642836 0.1828174565285672 0.2742261847928508 0.9396926207859084\n"
  "VERTEX_SE3:QUAT 1 2.565511108649531 -0.9024022660723916 -0.08690219216824913 0.13379681483404643 0.15451922325307 0.4981848316688047 0.8426352090202833\n"
  "VERTEX_SE3:QUAT 2 0.036091155718689816 -0.33422222411574576 1.0441177641709338 0.305815187951184 0.571962016536985 0.20966809734518446 0.7316937962105311\n"
  "VERTEX_SE3:QUAT 3 1.7874355266376964 -2.143051095232039 2.3328888879421275 0.5074039822415612 -0.32388310328950454 0.6999261557864314 0.38437522117716394\n"
  "VERTEX_SE3:QUAT 4 1.6945188955029584 -0.689837792710088 1.3950522299724062 0.17989842255989094 -0.15048480925445692 0.22625674263853296 0.94540931143855\n")
eval(0 rotated3 rotated3.g2o --reference ref3.g2o --json)
equals("${rotated3_out}" dimension 3)
equals("${rotated3_out}" poses_matched 5)
tiny("${rotated3_out}" ate_translation_rmse ate_rotation_rmse_deg rpe_translation_rmse
     rpe_rotation_rmse_deg)

# ---- 3D: one pose moved by a known amount ------------------------------------------------
# The result has poses 0-3 of ref3 (4 only in the reference), pose 3 moved by
# d = 0.2 (3 - centroid) = (-0.1, -0.1, 0.3) and turned by 0.2 rad about (1, 1, 1). The
# cross-covariance is then symmetric positive definite, so the best rotation is the
# identity; as in 2D, ATE = |d| sqrt(3) / 4 with |d| = sqrt(0.11), ATE rotation =
# 0.2 / sqrt(4) rad, RPE = |d| / sqrt(3) and 0.2 / sqrt(3) rad, extent = sqrt(9/4) = 1.5.
file(WRITE "${WORK}/moved3.g2o"
  "VERTEX_SE3:QUAT 0 0.0 0.0 0.0 0.0 0.0 0.0 1.0\n"
  "VERTEX_SE3:QUAT 1 2.0 0.0 0.0 0.0 0.0 0.24740395925452294 0.9689124217106447\n"
  "VERTEX_SE3:QUAT 2 0.0 2.0 0.0 0.33900504942104487 0.33900504942104487 0.0 0.8775825618903728\n"
  "VERTEX_SE3:QUAT 3 -0.1 -0.1 2.3 0.19009870929962067 -0.39047060558459007 0.7413372154744547 0.5116779454399063\n")
eval(0 moved3 moved3.g2o --reference ref3.g2o --json)
equals("${moved3_out}" poses_matched 4)
equals("${moved3_out}" poses_only_result 0)
equals("${moved3_out}" poses_only_reference 1)
within("${moved3_out}" ate_translation_rmse 0.14361406601983664 0.14361406630706477)  # 0.1436140661634507
within("${moved3_out}" ate_rotation_rmse_deg 5.729577945578655 5.729577957037812)     # 5.729577951308233
within("${moved3_out}" rpe_translation_rmse 0.19148542135978222 0.19148542174275307)  # 0.19148542155126763
within("${moved3_out}" rpe_rotation_rmse_deg 6.615946738445558 6.615946751677452)     # 6.615946745061505
within("${moved3_out}" extent_rms 1.4999999985 1.5000000015000001)                    # 1.5

# ---- loop rejection ------------------------------------------------------------------------
# Pair 5 9 is in the weights three times and a false loop twice: the later two lines (7 and
# 10) are the false ones. 9 5 is a different (true) loop. With T = 0.01:
#   line  pair  weight  state     truth  verdict
#   2     0 4   1       accepted  true   accepted
#   3     1 5   0.9     accepted  true   accepted
#   4     5 9   1       accepted  true   accepted
#   5     2 6   0.005   accepted  true   rejected (weight)  FP
#   6     2 7   0       pruned    false  rejected           TP
#   7     5 9   0.5     accepted  false  accepted           FN
#   8     3 8   0.2     accepted  true   accepted
#   9     4 9   0.001   accepted  true   rejected (weight)  FP
#   10    5 9   0       pruned    false  rejected           TP
#   11    9 5   0.002   accepted  true   rejected (weight)  FP
# rejected 5, TP 2, FP 3, FN 1: precision 2/5, recall 2/3; accepted 5, true loops 7, true
# loops accepted 4: inlier precision 4/5, inlier recall 4/7.
file(WRITE "${WORK}/loops.outliers" "# false loops\n2 7\n\n5 9\n5 9\n")
file(WRITE "${WORK}/weights.txt" "# from to weight state (one line per loop closure)\n"
  "0 4 1 accepted\n1 5 0.9 accepted\n5 9 1 accepted\n2 6 0.005 accepted\n2 7 0 pruned\n"
  "5 9 0.5 accepted\n3 8 0.2 accepted\n4 9 0.001 accepted\n5 9 0 pruned\n9 5 0.002 accepted\n")
eval(0 loops square_moved.g2o --reference square.txt --outliers loops.outliers
     --weights weights.txt --json --list)
equals("${loops_out}" loops 10)
equals("${loops_out}" outliers 3)
equals("${loops_out}" rejected 5)
equals("${loops_out}" true_positives 2)
equals("${loops_out}" false_positives 3)
equals("${loops_out}" false_negatives 1)
within("${loops_out}" precision 0.3999999996 0.4000000004)
within("${loops_out}" recall 0.666666666 0.6666666673333334)
within("${loops_out}" inlier_precision 0.7999999992 0.8000000008)
within("${loops_out}" inlier_recall 0.5714285708571428 0.571428572)
equals("${loops_out}" reject_below 0.01)
contains(loops "${loops_out}" "\"false_negative_pairs\":[[5,9]]")
contains(loops "${loops_out}" "\"false_positive_pairs\":[[2,6],[4,9],[9,5]]")
within("${loops_out}" ate_translation_rmse 0.18371173052502662 0.18371173089245008)

# Text output and --list name the lines; a lower threshold leaves only the pruned loops.
eval(0 loops_text square_moved.g2o --reference square.txt --outliers loops.outliers
     --weights weights.txt --list)
contains(loops_text "${loops_text_out}" "precision 0.4, recall 0.666667 (TP 2, FP 3, FN 1")
contains(loops_text "${loops_text_out}" "false-neg  5 9 (weight 0.5, accepted, weights.txt line 7)")
contains(loops_text "${loops_text_out}" "false-pos  9 5 (weight 0.002, accepted, weights.txt line 11)")
eval(0 loops_low square_moved.g2o --reference square.txt --outliers loops.outliers
     --weights weights.txt --reject-below 0.0001 --json)
equals("${loops_low_out}" rejected 2)
equals("${loops_low_out}" true_positives 2)
equals("${loops_low_out}" false_positives 0)
equals("${loops_low_out}" precision 1)
equals("${loops_low_out}" inlier_precision 0.875)
equals("${loops_low_out}" inlier_recall 1)
equals("${loops_low_out}" reject_below 0.0001)

# Nothing rejected but one false loop: precision is reported as 1, recall shows the miss.
file(WRITE "${WORK}/one.outliers" "1 3\n")
file(WRITE "${WORK}/all_accepted.txt" "0 2 1 accepted\n1 3 0.9 accepted\n")
eval(0 none_rejected square_moved.g2o --reference square.txt --outliers one.outliers
     --weights all_accepted.txt --json)
equals("${none_rejected_out}" rejected 0)
equals("${none_rejected_out}" precision 1)
equals("${none_rejected_out}" recall 0)
equals("${none_rejected_out}" inlier_precision 0.5)

# No false loops and no loops at all (empty files): every rate is 1.
file(WRITE "${WORK}/empty.outliers" "")
file(WRITE "${WORK}/no_loops.txt" "# from to weight state (one line per loop closure)\n")
eval(0 no_loops square_moved.g2o --reference square.txt --outliers empty.outliers
     --weights no_loops.txt --json)
equals("${no_loops_out}" loops 0)
equals("${no_loops_out}" outliers 0)
equals("${no_loops_out}" precision 1)
equals("${no_loops_out}" recall 1)
equals("${no_loops_out}" inlier_precision 1)
equals("${no_loops_out}" inlier_recall 1)
eval(0 no_outliers square_moved.g2o --reference square.txt --outliers empty.outliers
     --weights weights.txt --json)
equals("${no_outliers_out}" true_positives 0)
equals("${no_outliers_out}" false_positives 5)
equals("${no_outliers_out}" precision 0)
equals("${no_outliers_out}" recall 1)

# ---- errors ----------------------------------------------------------------------------------
pgem_fails(3 missing "no_such.g2o: cannot open" eval no_such.g2o --reference square.txt)
pgem_fails(3 missing_weights "no_such.txt: cannot open" eval square_moved.g2o
           --reference square.txt --outliers loops.outliers --weights no_such.txt)

file(WRITE "${WORK}/bad_weights.txt" "# from to weight state\n0 4 1 accepted\n1 5 heavy accepted\n")
pgem_fails(1 bad_weight "bad_weights.txt:3: field 3 (weight) is not a finite number" eval
           square_moved.g2o --reference square.txt --outliers loops.outliers
           --weights bad_weights.txt)
file(WRITE "${WORK}/bad_state.txt" "0 4 1 accepted\n\n1 5 0.5 maybe\n")
pgem_fails(1 bad_state "bad_state.txt:3: field 4 (state) must be accepted or pruned" eval
           square_moved.g2o --reference square.txt --outliers loops.outliers
           --weights bad_state.txt)
file(WRITE "${WORK}/short_weights.txt" "0 4 1\n")
pgem_fails(1 short_weights "short_weights.txt:1: expected 4 fields" eval square_moved.g2o
           --reference square.txt --outliers loops.outliers --weights short_weights.txt)
file(WRITE "${WORK}/bad.outliers" "2 7\n2 -7\n")
pgem_fails(1 bad_outliers "bad.outliers:2: field 2 (to) is not an unsigned 64-bit id" eval
           square_moved.g2o --reference square.txt --outliers bad.outliers --weights weights.txt)

file(WRITE "${WORK}/absent.outliers" "2 7\n7 2\n")
pgem_fails(1 absent "absent.outliers:2: false loop 7 2 is not in weights.txt" eval square_moved.g2o
           --reference square.txt --outliers absent.outliers --weights weights.txt)
file(WRITE "${WORK}/thrice.outliers" "# 5 9 is in weights.txt three times\n5 9\n5 9\n5 9\n5 9\n")
pgem_fails(1 thrice
           "thrice.outliers:5: false loop 5 9 is listed 4 times but weights.txt has it only 3 times"
           eval square_moved.g2o --reference square.txt --outliers thrice.outliers
           --weights weights.txt)

# Issue 31, row 9 (e): weights that are not the result graph's were scored (another graph's
# weights against this result gave precision 1, recall 1). A result with edges vouches for
# its loop closures: the weights must list exactly them (as a multiset of (from, to) pairs),
# or eval refuses, naming the file, the line and the ids. (A vertex-only result cannot.)
file(WRITE "${WORK}/square_loops.g2o"
  "VERTEX_SE2 0 0 0 0\n"
  "VERTEX_SE2 1 2 0 1.5707963267948966\n"
  "VERTEX_SE2 2 2 2 3.141592653589793\n"
  "VERTEX_SE2 3 -0.3 2.3 -1.4707963267948966\n"
  "EDGE_SE2 0 1 2 0 1.5707963267948966 1 0 0 1 0 1\n"
  "EDGE_SE2 1 2 2 0 1.5707963267948966 1 0 0 1 0 1\n"
  "EDGE_SE2 2 3 2 0 1.5707963267948966 1 0 0 1 0 1\n"
  "EDGE_SE2 3 1 0 2 0 1 0 0 1 0 1\n"
  "EDGE_SE2 0 2 2 2 3.14 1 0 0 1 0 1\n")
file(WRITE "${WORK}/square_loops.outliers" "3 1\n")
file(WRITE "${WORK}/square_loops.weights" "# from to weight state\n3 1 0 pruned\n0 2 1 accepted\n")
eval(0 own_weights square_loops.g2o --reference square.txt --outliers square_loops.outliers
     --weights square_loops.weights --json)
equals("${own_weights_out}" true_positives 1)
equals("${own_weights_out}" recall 1)
pgem_fails(1 foreign_weights
           "pgem eval: square_loops.g2o:9: loop closure 0 -> 2 has no line in weights.txt (square_loops.g2o has 2 loop closures, weights.txt lists 10): the weights belong to another graph"
           eval square_loops.g2o --reference square.txt --outliers empty.outliers
           --weights weights.txt)
file(WRITE "${WORK}/three.weights" "0 2 1 accepted\n3 1 0 pruned\n2 0 1 accepted\n")
pgem_fails(1 extra_loop
           "pgem eval: three.weights:3: loop closure 2 -> 0 is not a loop closure of square_loops.g2o (it has 2, three.weights lists 3): the weights belong to another graph"
           eval square_loops.g2o --reference square.txt --outliers empty.outliers
           --weights three.weights)
file(WRITE "${WORK}/one_of_two.weights" "0 2 1 accepted\n")
pgem_fails(1 missing_loop
           "pgem eval: square_loops.g2o:8: loop closure 3 -> 1 has no line in one_of_two.weights (square_loops.g2o has 2 loop closures, one_of_two.weights lists 1): the weights belong to another graph"
           eval square_loops.g2o --reference square.txt --outliers empty.outliers
           --weights one_of_two.weights)

pgem_fails(1 dimensions "dimensions differ: rotated3.g2o is 3D, square.txt is 2D" eval rotated3.g2o
           --reference square.txt)
file(WRITE "${WORK}/other_ids.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 50 1 1 1\nVERTEX_SE2 51 1 1 1\n")
pgem_fails(1 one_match "1 pose id(s) in both other_ids.g2o and square.txt; at least 2 must match"
           eval other_ids.g2o --reference square.txt)
file(WRITE "${WORK}/empty.g2o" "# nothing\n")
pgem_fails(1 empty "empty.g2o has no poses" eval empty.g2o --reference square.txt)
file(WRITE "${WORK}/broken.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 zero 0\n")
pgem_fails(1 broken "broken.g2o:2:" eval square_moved.g2o --reference broken.g2o)
file(WRITE "${WORK}/bad_quat.g2o" "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 2\n")
pgem_fails(1 bad_quat "bad_quat.g2o:2: pose 1 has a quaternion of norm 2" eval bad_quat.g2o
           --reference ref3.g2o)

# ---- command line ------------------------------------------------------------------------------
pgem_fails(2 no_args "usage: pgem eval RESULT --reference REF" eval)
eval(0 help --help)
contains(help "${help_out}" "usage: pgem eval RESULT --reference REF")
pgem_fails(2 no_reference "--reference REF are required" eval square_moved.g2o)
pgem_fails(2 outliers_alone "--outliers and --weights go together" eval square_moved.g2o
           --reference square.txt --outliers loops.outliers)
pgem_fails(2 weights_alone "--outliers and --weights go together" eval square_moved.g2o
           --reference square.txt --weights weights.txt)
pgem_fails(2 bad_threshold "--reject-below needs a non-negative number" eval square_moved.g2o
           --reference square.txt --outliers loops.outliers --weights weights.txt --reject-below -1)
pgem_fails(2 list_alone "--list needs --outliers and --weights" eval square_moved.g2o
           --reference square.txt --list)
pgem_fails(2 unknown "unknown option '--align'" eval square_moved.g2o --reference square.txt
           --align sim3)
pgem_fails(2 dangling "--reference needs a file name" eval square_moved.g2o --reference)
