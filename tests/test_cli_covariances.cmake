# pgem optimize --covariances: one line per pose (id, then the upper triangle of its marginal
# covariance), the held first pose zero, every other diagonal positive, in 2D and 3D; the JSON
# keys; a file that cannot be written; a graph that cannot be solved writes nothing.
# Run by CTest as: cmake -DPGEM=<pgem> -DWORK=<folder> -P test_cli_covariances.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")

# check_lines(<label> <file> <poses> <values per line> <diagonal positions>)
function(check_lines label path poses values diagonal)
  file(STRINGS "${WORK}/${path}" lines)
  list(LENGTH lines count)
  if(NOT count EQUAL ${poses})
    fail("${label}: ${count} lines in ${path}, expected ${poses}")
  endif()
  math(EXPR fields "${values} + 1")
  set(index 0)
  foreach(line IN LISTS lines)
    string(REPLACE " " ";" numbers "${line}")
    list(LENGTH numbers got)
    if(NOT got EQUAL fields)
      fail("${label}: line '${line}' has ${got} fields, expected ${fields}")
    endif()
    foreach(position IN LISTS diagonal)
      list(GET numbers ${position} value)
      if(index EQUAL 0 AND NOT value STREQUAL "0")
        fail("${label}: the held first pose has '${line}', expected zeros")
      elseif(index GREATER 0 AND (value MATCHES "^-" OR value STREQUAL "0"))
        fail("${label}: line '${line}': a diagonal entry is not positive")
      endif()
    endforeach()
    math(EXPR index "${index} + 1")
  endforeach()
endfunction()

pgem_ok(sim2 simulate -o sim2.g2o --poses 300 --seed 4)
pgem_ok(opt2 optimize sim2.g2o --covariances sim2.cov --json --quiet)
equals("${opt2_out}" covariances sim2.cov)
json_value("${opt2_out}" covariance_seconds seconds)
check_lines(2d sim2.cov 300 6 "1;4;6")

pgem_ok(sim3 simulate -o sim3.g2o --world sphere --poses 100 --seed 4)
pgem_ok(opt3 optimize sim3.g2o --robust em --covariances sim3.cov --quiet)
contains(opt3 "${opt3_out}" "covariances of 100 poses")
check_lines(3d sim3.cov 100 21 "1;7;12;16;19;21")

# the file cannot be written: exit 3, the path named
pgem_fails(3 bad_path "missing/out.cov" optimize sim2.g2o --covariances missing/out.cov --quiet)
pgem_fails(2 no_value "--covariances" optimize sim2.g2o --covariances)
