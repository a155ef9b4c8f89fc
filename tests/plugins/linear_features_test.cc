// Placeholder until the linear_features tests land.
