"""Built-in configuration files (hyperparameters per world and algorithm)."""
