// Independent runs of stochastic radiosity for the statistical tests (unbiasedness, agreement
// of the devices): per chart, the mean over runs of the area-weighted mean luminance of each
// run's average radiosity, with its standard error.
#pragma once

#include "penumbra/radiosity/stochastic.h"

#include <functional>
#include <string>
#include <vector>

namespace penumbra {

struct ChartMeans {
  std::vector<double> mean, standard_error;
};

// The runs solve the built-in scene `name` with seeds first, ..., first + runs - 1, each for
// its burn-in plus `averaged` iterations; `solve` iterates the solver it is given (on a device
// of its choice) and returns the average per element.
using StochasticSolve = std::function<std::vector<glm::dvec3>(StochasticRadiosity&)>;
ChartMeans stochasticChartMeans(const std::string& name, StochasticOptions o, int first, int runs,
                                int averaged, const StochasticSolve& solve);

// The furnace (emission and reflectance 0.5 inside a closed cube: B = 2 pi): each of the six
// inside faces' mean within 4 standard errors of 2 pi, and each standard error below
// `largest_standard_error` of it (what bias the test can see). `label` heads the lines printed.
void expectFurnaceClosedForm(const ChartMeans& m, double largest_standard_error,
                             const std::string& label);

// A square lamp (1 m, emission 3, facing down, reflectance 0) 1 m over a 4 m floor (rho 0.5),
// nothing else: the first shots carry all the light there is.
Scene lampOverFloorScene();

// The relative RMS difference of the solver's estimate from `reference` per element (luminance,
// area-weighted).
double relativeRmsError(const StochasticRadiosity& sr, const std::vector<glm::dvec3>& reference);

}  // namespace penumbra
