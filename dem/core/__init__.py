"""The experiment, the same for every engine: driver, cell, contact law, protocol, measurement, checks, files."""
