// The umbrella header: everything a user of eci needs, from one include.
#pragma once

#include "concepts.hpp"
#include "integrate.hpp"
#include "registry.hpp"
#include "run.hpp"
#include "steppers/compensated_c_pc.hpp"
#include "steppers/conservative_euler.hpp"
#include "steppers/conservative_rk.hpp"
#include "steppers/explicit_rk.hpp"
#include "steppers/implicit_midpoint.hpp"
#include "steppers/kahan.hpp"
#include "steppers/transformed_rk.hpp"
#include "tableaus.hpp"
