# pgem_warnings(target): the project's warning set (and -Werror with PGEM_WERROR).
function(pgem_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wshadow -Wdouble-promotion
    -Wundef -Wcast-qual -Wpointer-arith $<$<COMPILE_LANGUAGE:C>:-Wstrict-prototypes
    -Wmissing-prototypes>)
  if(PGEM_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
