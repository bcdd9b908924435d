// The Catch2 main, alone in its file so that test files recompile without it.
#define CATCH_CONFIG_MAIN
#include <catch2/catch.hpp>
