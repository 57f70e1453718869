"""Safety to ISO/TS 15066: speed and separation monitoring, power and force limiting, contacts."""
