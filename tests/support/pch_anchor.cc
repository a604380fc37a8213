// The one source of oaipp_test_pch (tests/CMakeLists.txt), the target that
// builds the precompiled header the test and benchmark programs share: a
// target needs a source to compile its header with.
