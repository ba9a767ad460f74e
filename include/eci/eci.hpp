// The umbrella header: everything a user of eci needs, from one include (the models are included one by one,
// from include/eci/models/; the exact solutions need Boost.Math; solve_model.hpp is for the one translation unit
// that compiles a model's runs, memory.hpp for front ends that guard a request's memory).
#pragma once

#include "adaptive.hpp"
#include "compensated_sum.hpp"
#include "concepts.hpp"
#include "dynamic_sink.hpp"
#include "format.hpp"
#include "integrate.hpp"
#include "invariants.hpp"
#include "registry.hpp"
#include "run.hpp"
#include "solve.hpp"
#include "state.hpp"
#include "steps.hpp"
#include "steppers/compensated_c_pc.hpp"
#include "steppers/conservative_euler.hpp"
#include "steppers/conservative_rk.hpp"
#include "steppers/embedded_rk.hpp"
#include "steppers/explicit_rk.hpp"
#include "steppers/implicit_midpoint.hpp"
#include "steppers/kahan.hpp"
#include "steppers/projection.hpp"
#include "steppers/radicand_remedy.hpp"
#include "steppers/relaxation_rk.hpp"
#include "steppers/symplectic.hpp"
#include "steppers/transformed_embedded_rk.hpp"
#include "steppers/transformed_rk.hpp"
#include "tableaus.hpp"

#include <eci/version.hpp>  // (generated: in the build tree's include/ and the install prefix's)
