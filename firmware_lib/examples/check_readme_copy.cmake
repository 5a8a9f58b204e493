# Fails unless README.md quotes EXAMPLE's text whole: the README's copy of the example cannot drift
# from the program the tests build and run.
file(READ ${EXAMPLE} example)
file(READ ${README} readme)
string(FIND "${readme}" "${example}" at)
if(at EQUAL -1)
  message(FATAL_ERROR "${README} does not quote ${EXAMPLE} as it is: copy the file into its code block")
endif()
