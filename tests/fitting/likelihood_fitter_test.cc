// Placeholder until the likelihood fitter tests land.
