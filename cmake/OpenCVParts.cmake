# Debian ships OpenCV's CMake package only in the all-modules libopencv-dev
# meta package (it pulls in VTK, Qt and more). The project needs five modules,
# installed as their own -dev packages, so it builds imported targets here,
# in layers, so that the server links only the first:
#   oaipp::opencv            core, imgproc, calib3d (camera model, drawing)
#   oaipp::opencv_imgcodecs  + imgcodecs (tests decode PNGs; Debian builds it
#                            with GDAL, which is most of an image's size)
#   oaipp::opencv_videoio    + videoio (the client's mission videos)
find_path(OAIPP_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
add_library(oaipp_opencv INTERFACE)
target_include_directories(oaipp_opencv SYSTEM INTERFACE ${OAIPP_OPENCV_INCLUDE_DIR})
foreach(part core imgproc calib3d)
  find_library(OAIPP_OPENCV_${part}_LIBRARY opencv_${part} REQUIRED)
  target_link_libraries(oaipp_opencv INTERFACE ${OAIPP_OPENCV_${part}_LIBRARY})
endforeach()
add_library(oaipp::opencv ALIAS oaipp_opencv)

find_library(OAIPP_OPENCV_imgcodecs_LIBRARY opencv_imgcodecs REQUIRED)
add_library(oaipp_opencv_imgcodecs INTERFACE)
target_link_libraries(oaipp_opencv_imgcodecs INTERFACE oaipp_opencv
  ${OAIPP_OPENCV_imgcodecs_LIBRARY})
add_library(oaipp::opencv_imgcodecs ALIAS oaipp_opencv_imgcodecs)

find_library(OAIPP_OPENCV_videoio_LIBRARY opencv_videoio REQUIRED)
add_library(oaipp_opencv_videoio INTERFACE)
target_link_libraries(oaipp_opencv_videoio INTERFACE oaipp_opencv_imgcodecs ${OAIPP_OPENCV_videoio_LIBRARY})
add_library(oaipp::opencv_videoio ALIAS oaipp_opencv_videoio)
