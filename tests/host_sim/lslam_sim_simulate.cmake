# lslam-sim end to end on a simulated world: `simulate` writes the dataset and its truth, `run
# --truth --plot --json` prints one JSON object with the ground-truth keys and draws the map.
#   cmake -DLSLAM_SIM=path/to/lslam-sim -DWORK=scratch/dir -P lslam_sim_simulate.cmake

function(run_ok)
  execute_process(COMMAND "${LSLAM_SIM}" ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    string(JOIN " " line ${ARGN})
    message(FATAL_ERROR "lslam-sim ${line}: exit status ${status}, stderr:\n${err}")
  endif()
  set(stdout "${out}" PARENT_SCOPE)
endfunction()

# expect_json(WHAT KEY=VALUE...): each KEY of the last run's JSON equals its VALUE.
function(expect_json what)
  foreach(check ${ARGN})
    string(REPLACE "=" ";" pair "${check}")
    list(GET pair 0 key)
    list(GET pair 1 expected)
    string(JSON value ERROR_VARIABLE json_error GET "${stdout}" ${key})
    if(json_error OR NOT value EQUAL expected)
      message(FATAL_ERROR "${what}: ${key} = ${value} (expected ${expected})\n${stdout}")
    endif()
  endforeach()
endfunction()

file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")
foreach(world grid2d points3d)
  run_ok(simulate ${world} "${WORK}/${world}.g2o" --steps 150 --seed 4)
  foreach(file "${WORK}/${world}.g2o" "${WORK}/${world}.truth.g2o")
    if(NOT EXISTS "${file}")
      message(FATAL_ERROR "simulate ${world}: ${file} not written")
    endif()
  endforeach()
  run_ok(run "${WORK}/${world}.g2o" --truth "${WORK}/${world}.truth.g2o"
         --plot "${WORK}/${world}.svg" --json)
  # One JSON object (string(JSON) fails on anything else), with the truth's keys, each a small
  # positive number (metres and degrees of a 150-pose world with centimetre noise).
  foreach(key ate_position_rmse ate_rotation_rmse_deg landmark_rmse)
    string(JSON value ERROR_VARIABLE json_error GET "${stdout}" ${key})
    if(json_error)
      message(FATAL_ERROR "run ${world} --json: ${json_error}\n${stdout}")
    endif()
    if(NOT value GREATER 0 OR NOT value LESS 5)
      message(FATAL_ERROR "run ${world}: ${key} = ${value}")
    endif()
  endforeach()
  file(READ "${WORK}/${world}.svg" svg)
  string(FIND "${svg}" "<svg" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "run ${world} --plot: no <svg element")
  endif()
  message(STATUS "PASS: ${world}: simulate, run --truth --plot --json")
endforeach()

# --max-poses: a 600-step grid on 100 poses runs to the end; the JSON holds the compact keys, the
# solver holds 100 nodes and every pose of the file is scored against the truth.
run_ok(simulate grid2d "${WORK}/grid600.g2o" --steps 600 --landmarks 0 --seed 4)
run_ok(run "${WORK}/grid600.g2o" --max-poses 100 --no-batch --truth "${WORK}/grid600.truth.g2o"
       --json)
expect_json("run --max-poses" "nodes=100" "truth_poses=600" "poses=600" "max_poses=100")
foreach(key loop_closures_folded loop_closures_dropped relocalized_steps ate_position_rmse)
  string(JSON value ERROR_VARIABLE json_error GET "${stdout}" ${key})
  if(json_error)
    message(FATAL_ERROR "run --max-poses --json: ${json_error}\n${stdout}")
  endif()
endforeach()
message(STATUS "PASS: run --max-poses 100 --no-batch --json")

# --max-poses with landmarks: a 400-step points3d world on 100 poses.
run_ok(simulate points3d "${WORK}/points400.g2o" --steps 400 --seed 4)
run_ok(run "${WORK}/points400.g2o" --max-poses 100 --no-batch
       --truth "${WORK}/points400.truth.g2o" --json)
expect_json("run points3d --max-poses" "nodes=100" "truth_poses=400")
foreach(key landmarks landmark_rmse)
  string(JSON value ERROR_VARIABLE json_error GET "${stdout}" ${key})
  if(json_error OR NOT value GREATER 0 OR NOT value LESS 100)
    message(FATAL_ERROR "run points3d --max-poses: ${key} = ${value}\n${stdout}")
  endif()
endforeach()
message(STATUS "PASS: run points3d --max-poses 100 --no-batch --json")

# --out from an iSAM file, whose poses and points are numbered apart (points 0 and 1 beside poses
# 0-3): g2o has one id space, so the estimate's points are written past the poses (ids 4 and 5) and
# the file reads back with every variable and factor.
set(sqrt_info_3d "20 0 0 0 0 0 20 0 0 0 0 20 0 0 0 100 0 0 100 0 100")
file(WRITE "${WORK}/isam3d.txt"
     "EDGE3 0 1 1 0 0 0 0 0.1 ${sqrt_info_3d}\n"
     "POINT3 0 0 2 1 0 10 0 0 10 0 10\n"
     "POINT3 1 0 1 1 0 10 0 0 10 0 10\n"
     "POINT3 1 1 1 -1 0.5 10 0 0 10 0 10\n"
     "EDGE3 1 2 1 0 0 0 0 0.1 ${sqrt_info_3d}\n"
     "POINT3 2 1 0 -1.1 0.5 10 0 0 10 0 10\n"
     "EDGE3 2 3 1 0 0 0 0 0.1 ${sqrt_info_3d}\n"
     "POINT3 3 0 -1 1.2 0 10 0 0 10 0 10\n"
     "POINT3 3 1 -1 -1 0.5 10 0 0 10 0 10\n")
run_ok(run "${WORK}/isam3d.txt" --no-batch --out "${WORK}/isam3d.g2o" --json)
expect_json("run isam3d.txt" "poses=4" "landmarks=2" "factors=9")
file(STRINGS "${WORK}/isam3d.g2o" points REGEX "^VERTEX_TRACKXYZ ")
list(TRANSFORM points REPLACE "^VERTEX_TRACKXYZ ([0-9]+) .*" "\\1")
if(NOT points STREQUAL "4;5")
  message(FATAL_ERROR "run isam3d.txt --out: point ids '${points}' (expected 4;5)")
endif()
run_ok(run "${WORK}/isam3d.g2o" --no-batch --json)
expect_json("run isam3d.g2o (written by --out)" "poses=4" "landmarks=2" "factors=9")
message(STATUS "PASS: run an iSAM file --out: points renumbered past the poses, read back whole")
