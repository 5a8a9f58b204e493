cmake_policy(VERSION 3.25)
# cmake -DSIZE=... -DNM=... -DELF=... -DOUT=... -P size_report.cmake
# Writes the section sizes of a target program and the sizes of its largest objects (the solver,
# the embedded stream) to OUT, for CI to print.
execute_process(COMMAND ${SIZE} -A -d ${ELF} OUTPUT_VARIABLE sections COMMAND_ERROR_IS_FATAL ANY)
execute_process(COMMAND ${NM} -S -C --size-sort ${ELF} OUTPUT_VARIABLE symbols
                COMMAND_ERROR_IS_FATAL ANY)
get_filename_component(name ${ELF} NAME)
set(report "${name}\n")
foreach(section .text .ARM.exidx .data .bss)
  string(REPLACE "." "\\." pattern ${section})
  if(sections MATCHES "\n${pattern} +([0-9]+)")
    string(APPEND report "  ${section} ${CMAKE_MATCH_1} bytes\n")
  endif()
endforeach()
# nm -S: "address size type name", sizes in hex; the largest data objects (RAM or flash). The
# characters that CMake's lists treat specially are replaced first (demangled names hold them).
string(REPLACE "[" "(" symbols "${symbols}")
string(REPLACE "]" ")" symbols "${symbols}")
string(REPLACE ";" "," symbols "${symbols}")
string(REPLACE "\n" ";" lines "${symbols}")
list(REVERSE lines)
set(shown 0)
foreach(line IN LISTS lines)
  if(shown LESS 12 AND line MATCHES "^[0-9a-f]+ ([0-9a-f]+) [bBdDrRvV] (.*)$")
    math(EXPR bytes "0x${CMAKE_MATCH_1}")
    string(APPEND report "  object ${bytes} bytes: ${CMAKE_MATCH_2}\n")
    math(EXPR shown "${shown} + 1")
  endif()
endforeach()
file(WRITE ${OUT} "${report}")
