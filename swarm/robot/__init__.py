"""One robot: parameters, terrain modes, motion models, encoder data, drive patterns, calibration."""
