// All of segpath's concepts.
#pragma once

#include "segpath/concepts/bsdf.hpp"
#include "segpath/concepts/emitter.hpp"
#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/manifold.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/concepts/sensor.hpp"
