# The C example in README.md is tests/c_example.c, character for character (so the example
# the tests compile and run is the one users read).
file(READ ${README} readme)
file(READ ${EXAMPLE} example)
string(FIND "${readme}" "```c\n${example}```" at)
if(at EQUAL -1)
  message(FATAL_ERROR "README.md does not contain tests/c_example.c verbatim in a ```c block")
endif()
