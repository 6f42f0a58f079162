"""Device models: reader, passive tag, sense-a-tag, HIMR inertial tag, exciter."""
