# The executable's side of lslam-sim's usage errors (tests/host_sim/test_cli.cpp tests the parsing):
# each bad command line must exit with status 2 and print its message on stderr.
#   cmake -DLSLAM_SIM=path/to/lslam-sim -DDATASET=path/to/a.g2o -P lslam_sim_usage.cmake

# expect(MESSAGE ARG...): `lslam-sim ARG...` exits with 2 and stderr contains MESSAGE.
function(expect message)
  execute_process(COMMAND "${LSLAM_SIM}" ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  string(FIND "${err}" "${message}" at)
  string(JOIN " " line ${ARGN})
  if(NOT status EQUAL 2 OR at EQUAL -1)
    message(SEND_ERROR "lslam-sim ${line}: exit status ${status} (expected 2), stderr:\n${err}"
                       "expected on stderr: ${message}")
  else()
    message(STATUS "PASS: lslam-sim ${line}: ${message}")
  endif()
endfunction()

expect("unknown option \"--bogus\"" run --bogus "${DATASET}")
expect("unknown option \"--bogus\"" run "${DATASET}" --bogus)
expect("missing DATASET" run)
expect("--out needs a value" run "${DATASET}" --out)
expect("--out needs a value (found the option \"--json\")" run "${DATASET}" --out --json)
expect("unexpected argument" run "${DATASET}" "${DATASET}")
expect("--order given twice" run "${DATASET}" --order file --order online)
expect("--solve-every: invalid value \"0\"" run "${DATASET}" --solve-every 0)
expect("unknown option \"--bogus\"" generate --bogus out.g2o)
expect("--poses needs a value" generate out.g2o --poses)
expect("missing OUT.g2o" generate --seed 1)
expect("unknown command \"walk\"" walk)
expect("unknown world \"moon\"" simulate moon out.g2o)
expect("--steps: invalid value \"1\"" simulate grid2d out.g2o --steps 1)
expect("--max-poses: invalid value \"1\"" run "${DATASET}" --max-poses 1)
