# Debian ships OpenCV's CMake package only in the all-modules libopencv-dev
# meta package (it pulls in VTK, Qt and more). The project needs four modules,
# installed as their own -dev packages, so it builds an imported target here;
# videoio (the client's mission videos) is a target of its own so that the
# core and the server do not link it.
find_path(OAIPP_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
add_library(oaipp_opencv INTERFACE)
target_include_directories(oaipp_opencv SYSTEM INTERFACE ${OAIPP_OPENCV_INCLUDE_DIR})
foreach(part core imgproc calib3d imgcodecs)
  find_library(OAIPP_OPENCV_${part}_LIBRARY opencv_${part} REQUIRED)
  target_link_libraries(oaipp_opencv INTERFACE ${OAIPP_OPENCV_${part}_LIBRARY})
endforeach()
add_library(oaipp::opencv ALIAS oaipp_opencv)

find_library(OAIPP_OPENCV_videoio_LIBRARY opencv_videoio REQUIRED)
add_library(oaipp_opencv_videoio INTERFACE)
target_link_libraries(oaipp_opencv_videoio INTERFACE oaipp_opencv ${OAIPP_OPENCV_videoio_LIBRARY})
add_library(oaipp::opencv_videoio ALIAS oaipp_opencv_videoio)
