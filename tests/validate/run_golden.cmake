# Golden test driver (tests/validate/CMakeLists.txt): runs the built `candp2` with ARGS
# ('|'-separated) in WORKDIR, then compares its exit status with EXPECT_RC, its stdout with GOLDEN
# and its stderr with GOLDEN minus ".txt" plus ".stderr.txt" (an absent file means: no stderr).
# Comparison is byte for byte; a mismatch leaves the actual output in ACTUAL_DIR for `diff -u`.
# With the environment variable CANDP2_UPDATE_GOLDEN=1 the files are (re)written instead
# (docs/validate.md: review the diff before committing).
cmake_minimum_required(VERSION 3.25)

string(REPLACE "|" ";" run_args "${ARGS}")
execute_process(COMMAND ${CANDP2} ${run_args} WORKING_DIRECTORY ${WORKDIR}
                RESULT_VARIABLE run_rc OUTPUT_VARIABLE run_stdout ERROR_VARIABLE run_stderr
                TIMEOUT 20)
string(REGEX REPLACE "\\.txt$" ".stderr.txt" golden_stderr "${GOLDEN}")

if("$ENV{CANDP2_UPDATE_GOLDEN}" STREQUAL "1")
  file(WRITE "${GOLDEN}" "${run_stdout}")
  if(run_stderr STREQUAL "")
    file(REMOVE "${golden_stderr}")
  else()
    file(WRITE "${golden_stderr}" "${run_stderr}")
  endif()
  message(STATUS "written: ${GOLDEN}")
endif()

set(failed FALSE)
if(NOT run_rc STREQUAL EXPECT_RC)
  message(SEND_ERROR "candp2 ${ARGS}: exit status ${run_rc}, expected ${EXPECT_RC}")
  set(failed TRUE)
endif()

# compare(ACTUAL_VAR FILE WHAT): FILE must exist (stdout) or may be absent when ACTUAL is empty.
function(compare actual_var file what)
  set(expected "")
  if(EXISTS "${file}")
    file(READ "${file}" expected)
  elseif(what STREQUAL "stdout")
    message(SEND_ERROR "missing golden file ${file} (run with CANDP2_UPDATE_GOLDEN=1)")
    set(failed TRUE PARENT_SCOPE)
  endif()
  if(NOT "${${actual_var}}" STREQUAL "${expected}")
    get_filename_component(base "${file}" NAME)
    file(WRITE "${ACTUAL_DIR}/${base}" "${${actual_var}}")
    message(SEND_ERROR "candp2 ${ARGS}: ${what} differs from ${file}\n"
                       "  diff -u ${file} ${ACTUAL_DIR}/${base}")
    set(failed TRUE PARENT_SCOPE)
  endif()
endfunction()
compare(run_stdout "${GOLDEN}" stdout)
compare(run_stderr "${golden_stderr}" stderr)

if(failed)
  message(FATAL_ERROR "golden test failed")
endif()
