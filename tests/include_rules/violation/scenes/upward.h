#pragma once
// A scene header that reaches up into the solver: the include check must refuse it.
#include "scenes/scene.h"
#include "solver/solver.h"
