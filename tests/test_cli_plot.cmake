# pgem plot, end to end: writes a small 2D graph whose loop closures are set up by hand to
# fall into every class (true/false, accepted/rejected), a 3D graph, a before/after pair and
# a rotated ground truth, runs the tool and reads the SVG back: well formed, one <path> per
# kind of line with the expected number of strokes, the legend counts, and the errors.
# Run by CTest as: cmake -DPGEM=<pgem executable> -DWORK=<scratch folder> -P test_cli_plot.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# plot(<expected exit code> <name> args...): runs pgem plot; sets <name>_out and <name>_err.
macro(plot expected name)
  pgem_expect(${expected} ${name} plot ${ARGN})
endmacro()

# read_svg(<file> <variable>): the document, checked to start with <svg and end with </svg>.
function(read_svg file variable)
  file(READ "${WORK}/${file}" svg)
  string(STRIP "${svg}" stripped)
  if(NOT stripped MATCHES "^<svg xmlns=\"http://www.w3.org/2000/svg\"")
    fail("${file}: does not start with <svg xmlns=...")
  endif()
  if(NOT stripped MATCHES "</svg>$")
    fail("${file}: does not end with </svg>")
  endif()
  string(REGEX MATCHALL "<svg" opened "${svg}")
  list(LENGTH opened count)
  if(NOT count EQUAL 1)
    fail("${file}: ${count} <svg elements")
  endif()
  set(${variable} "${svg}" PARENT_SCOPE)
endfunction()

# strokes(<svg> <class> <expected list>): the <path class="CLASS"> elements, one per panel in
# order, have the given numbers of strokes (moveto commands); an empty list: no such path.
function(strokes svg class expected)
  string(REGEX MATCHALL "<path class=\"${class}\" [^>]* d=\"[^\"]*\"" paths "${svg}")
  set(counts "")
  foreach(path IN LISTS paths)
    string(REGEX REPLACE ".* d=\"([^\"]*)\"" "\\1" data "${path}")
    string(REGEX MATCHALL "M" moves "${data}")
    list(LENGTH moves moved)
    list(APPEND counts ${moved})
  endforeach()
  if(NOT "${counts}" STREQUAL "${expected}")
    fail("strokes of class '${class}': [${counts}], expected [${expected}]")
  endif()
endfunction()

# path_numbers(<svg> <class> <variable>): the coordinates of the first <path class="CLASS">
# in tenths of a pixel (integers, so CMake can compare them).
function(path_numbers svg class variable)
  string(REGEX MATCH "<path class=\"${class}\" [^>]* d=\"[^\"]*\"" path "${svg}")
  string(REGEX REPLACE ".* d=\"([^\"]*)\"" "\\1" data "${path}")
  string(REGEX MATCHALL "-?[0-9]+\\.[0-9]" numbers "${data}")
  string(REPLACE "." "" tenths "${numbers}")
  set(${variable} "${tenths}" PARENT_SCOPE)
endfunction()

# ---- a 2D square walk with seven loop closures ---------------------------------------------
# Loops (weights, outliers):        verdict        truth   class
#   7 0  weight 1     accepted      accepted       true    accepted
#   6 0  weight 0.9   accepted      accepted       true    accepted
#   5 0  weight 1     pruned        rejected       true    true-rejected
#   2 6  weight 0     pruned        rejected       false   rejected
#   3 7  weight 0.001 accepted      rejected (<0.01) false rejected
#   0 4  weight 0.5   accepted      accepted       false   missed
#   1 5  weight 0.005 accepted      rejected (<0.01) true  true-rejected
set(info "1 0 0 1 0 1")
file(WRITE "${WORK}/g2.g2o" "# a 2 m square, 8 poses\n"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nVERTEX_SE2 3 2 1 0\n"
  "VERTEX_SE2 4 2 2 0\nVERTEX_SE2 5 1 2 0\nVERTEX_SE2 6 0 2 0\nVERTEX_SE2 7 0 1 0\n")
foreach(k RANGE 0 6)
  math(EXPR next "${k} + 1")
  file(APPEND "${WORK}/g2.g2o" "EDGE_SE2 ${k} ${next} 1 0 0 ${info}\n")
endforeach()
foreach(pair "7 0" "6 0" "5 0" "2 6" "3 7" "0 4" "1 5")
  file(APPEND "${WORK}/g2.g2o" "EDGE_SE2 ${pair} 0 0 0 ${info}\n")
endforeach()
file(WRITE "${WORK}/w2.txt" "# from to weight state\n"
  "7 0 1 accepted\n6 0 0.9 accepted\n5 0 1 pruned\n2 6 0 pruned\n3 7 0.001 accepted\n"
  "0 4 0.5 accepted\n1 5 0.005 accepted\n")
file(WRITE "${WORK}/o2.outliers" "2 6\n3 7\n0 4\n")

# Weights and outliers: every class.
plot(0 full g2.g2o --weights w2.txt --outliers o2.outliers -o full.svg)
read_svg(full.svg svg)
strokes("${svg}" odometry "1")
strokes("${svg}" accepted "2")
strokes("${svg}" true-rejected "2")
strokes("${svg}" rejected "2")
strokes("${svg}" missed "1")
strokes("${svg}" truth "")
foreach(text "<title>g2.g2o</title>" "7 odometry edges" "2 true loops accepted"
             "2 false loops rejected" "2 true loops rejected" "1 false loop accepted (missed)"
             "2D, 8 poses, 7 loop closures" "width=\"1000\"" "class=\"scale\"")
  contains(full "${svg}" "${text}")
endforeach()
# The odometry chain passes through the 8 poses of the square: 8 points, 16 numbers.
path_numbers("${svg}" odometry odometry)
list(LENGTH odometry numbers)
if(NOT numbers EQUAL 16)
  fail("full: the odometry path has ${numbers} coordinates, expected 16")
endif()
# Equal aspect ratio: pose 2 - pose 0 (2 m along x) is as long as pose 4 - pose 2 (2 m up).
list(GET odometry 0 x0)
list(GET odometry 4 x2)
list(GET odometry 5 y2)
list(GET odometry 9 y4)
math(EXPR across "${x2} - ${x0}")
math(EXPR up "${y2} - ${y4}")
if(across LESS 100 OR NOT across EQUAL up)
  fail("full: 2 m across is ${across} tenths of a pixel, 2 m up ${up}")
endif()

# Weights alone: rejected is rejected, whatever the truth.
plot(0 weights g2.g2o --weights w2.txt -o weights.svg)
read_svg(weights.svg svg)
strokes("${svg}" accepted "3")
strokes("${svg}" rejected "4")
strokes("${svg}" true-rejected "")
strokes("${svg}" missed "")
contains(weights "${svg}" "3 loops accepted")
contains(weights "${svg}" "4 loops rejected (pruned or weight &lt; 0.01)")

# Outliers alone (the corrupted input): nothing judged, the false loops marked.
plot(0 outliers g2.g2o --outliers o2.outliers -o outliers.svg)
read_svg(outliers.svg svg)
strokes("${svg}" accepted "4")
strokes("${svg}" missed "3")
strokes("${svg}" rejected "")
contains(outliers "${svg}" "3 false loops")

# Neither: the graph's loop closures, all green; a title that needs escaping; a width.
plot(0 plain g2.g2o --title "A <b> & \"c\"" --width 600 -o plain.svg)
read_svg(plain.svg svg)
strokes("${svg}" accepted "7")
contains(plain "${svg}" "<title>A &lt;b&gt; &amp; &quot;c&quot;</title>")
contains(plain "${svg}" "width=\"600\"")

# Ground truth: the graph turned by 90 degrees and moved; aligned back, it lies on the
# odometry chain (same pixels to a tenth).
file(WRITE "${WORK}/truth2.g2o"
  "VERTEX_SE2 0 10 5 1.5707963267948966\nVERTEX_SE2 1 10 6 1.5707963267948966\n"
  "VERTEX_SE2 2 10 7 1.5707963267948966\nVERTEX_SE2 3 9 7 1.5707963267948966\n"
  "VERTEX_SE2 4 8 7 1.5707963267948966\nVERTEX_SE2 5 8 6 1.5707963267948966\n"
  "VERTEX_SE2 6 8 5 1.5707963267948966\nVERTEX_SE2 7 9 5 1.5707963267948966\n")
plot(0 truth g2.g2o --truth truth2.g2o -o truth.svg)
read_svg(truth.svg svg)
strokes("${svg}" truth "1")
contains(truth "${svg}" "ground truth, rigidly aligned (8 poses matched)")
path_numbers("${svg}" odometry odometry)
path_numbers("${svg}" truth truth)
list(LENGTH truth numbers)
if(NOT numbers EQUAL 16)
  fail("truth: the truth path has ${numbers} coordinates, expected 16")
endif()
foreach(k RANGE 15)
  list(GET odometry ${k} a)
  list(GET truth ${k} b)
  math(EXPR difference "${a} - ${b}")
  if(difference GREATER 1 OR difference LESS -1)
    fail("truth: coordinate ${k} is ${b} tenths, the odometry's ${a}")
  endif()
endforeach()

# Before/after: the same loops in both panels, each panel with its own odometry chain.
file(WRITE "${WORK}/before2.g2o"
  "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0.1 0\nVERTEX_SE2 2 2 0.3 0\nVERTEX_SE2 3 2.2 1.3 0\n"
  "VERTEX_SE2 4 2.5 2.4 0\nVERTEX_SE2 5 1.4 2.6 0\nVERTEX_SE2 6 0.5 2.9 0\n"
  "VERTEX_SE2 7 0.6 1.8 0\n")
plot(0 pair g2.g2o --before before2.g2o --weights w2.txt --outliers o2.outliers -o pair.svg)
read_svg(pair.svg svg)
strokes("${svg}" odometry "1;1")
strokes("${svg}" rejected "2;2")
strokes("${svg}" missed "1;1")
contains(pair "${svg}" "before: before2.g2o")
contains(pair "${svg}" "after: g2.g2o")
contains(pair "${svg}" "width=\"1600\"")

# ---- 3D: two views side by side --------------------------------------------------------------
set(info3 "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1")
file(WRITE "${WORK}/g3.g2o"
  "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0.5 0 0 0 1\n"
  "VERTEX_SE3:QUAT 2 1 1 1 0 0 0 1\nVERTEX_SE3:QUAT 3 0 1 1.5 0 0 0 1\n"
  "VERTEX_SE3:QUAT 4 0 0 2 0 0 0 1\n"
  "EDGE_SE3:QUAT 0 1 1 0 0.5 0 0 0 1 ${info3}\nEDGE_SE3:QUAT 1 2 0 1 0.5 0 0 0 1 ${info3}\n"
  "EDGE_SE3:QUAT 2 3 -1 0 0.5 0 0 0 1 ${info3}\nEDGE_SE3:QUAT 3 4 0 -1 0.5 0 0 0 1 ${info3}\n"
  "EDGE_SE3:QUAT 4 0 0 0 -2 0 0 0 1 ${info3}\nEDGE_SE3:QUAT 3 0 0 -1 -1.5 0 0 0 1 ${info3}\n")
file(WRITE "${WORK}/w3.txt" "# from to weight state\n4 0 1 accepted\n3 0 0 pruned\n")
file(WRITE "${WORK}/o3.outliers" "3 0\n")
plot(0 three g3.g2o --weights w3.txt --outliers o3.outliers -o three.svg)
read_svg(three.svg svg)
strokes("${svg}" odometry "1;1")
strokes("${svg}" accepted "1;1")
strokes("${svg}" rejected "1;1")
strokes("${svg}" missed "")
foreach(text "top (x-y)" "side (x-z)" "3D, 5 poses, 2 loop closures" "4 odometry edges"
             "1 true loop accepted" "1 false loop rejected" "width=\"1600\"")
  contains(three "${svg}" "${text}")
endforeach()
string(REGEX MATCHALL "class=\"scale\"" bars "${svg}")
list(LENGTH bars count)
if(NOT count EQUAL 1)
  fail("three: ${count} scale bars, expected 1 (the two views share a scale)")
endif()

# ---- errors ---------------------------------------------------------------------------------
plot(0 help --help)
contains(help "${help_out}" "usage: pgem plot GRAPH")
plot(2 no_arguments)
pgem_fails(2 no_output "pgem plot: " plot g2.g2o)
plot(2 two_graphs g2.g2o g3.g2o -o x.svg)
plot(2 unknown_option g2.g2o --colour red -o x.svg)
plot(2 no_value g2.g2o -o x.svg --weights)
plot(2 bad_width g2.g2o --width abc -o x.svg)
plot(2 small_width g2.g2o --width 10 -o x.svg)
plot(3 missing_graph nothing.g2o -o x.svg)
plot(3 missing_weights g2.g2o --weights nothing.txt -o x.svg)
plot(3 missing_before g2.g2o --before nothing.g2o -o x.svg)
plot(3 unwritable g2.g2o -o no_such_folder/x.svg)

file(WRITE "${WORK}/bad.g2o" "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 one 0 0\n")
pgem_fails(1 malformed "bad.g2o:2" plot bad.g2o -o bad.svg)
file(WRITE "${WORK}/empty.g2o" "# nothing here\n")
pgem_fails(1 empty "has no poses" plot empty.g2o -o empty.svg)
file(WRITE "${WORK}/w_bad.txt" "# from to weight state\n7 0 1 accepted\n6 0 heavy accepted\n")
pgem_fails(1 bad_weights "w_bad.txt:3" plot g2.g2o --weights w_bad.txt -o bad_weights.svg)
file(WRITE "${WORK}/o_bad.outliers" "2 6\n4 1\n")
pgem_fails(1 bad_outliers "o_bad.outliers:2" plot g2.g2o --weights w2.txt --outliers o_bad.outliers
           -o bad_outliers.svg)
file(WRITE "${WORK}/w_unknown.txt" "7 0 1 accepted\n7 99 1 pruned\n")
pgem_fails(1 unknown_pose "w_unknown.txt:2: loop 7 99: pose 99 is not in" plot g2.g2o
           --weights w_unknown.txt -o unknown_pose.svg)
pgem_fails(1 truth_dimension "dimensions differ" plot g2.g2o --truth g3.g2o -o truth_dimension.svg)
plot(1 before_dimension g2.g2o --before g3.g2o -o before_dimension.svg)
foreach(name bad empty bad_weights bad_outliers unknown_pose truth_dimension before_dimension)
  if(EXISTS "${WORK}/${name}.svg")
    fail("${name}.svg was written although the input was rejected")
  endif()
endforeach()
