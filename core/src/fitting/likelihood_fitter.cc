// Placeholder until the likelihood fitter lands.
