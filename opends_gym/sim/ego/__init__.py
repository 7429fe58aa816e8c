"""The driver's car: vehicle spec, the fast single-track body, the OpenDS powertrain and the
compiled per-step kernels (shared with the native batch), and `EgoCar`, which drives a body
(fast or bullet) with driver inputs."""
