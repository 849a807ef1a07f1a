// The translation unit that builds the tests' one precompiled header (tests/CMakeLists.txt):
// GoogleTest, Eigen and Boost.Odeint are parsed once for all test files.
