"""Traffic cars and pedestrians (OpenDS `PhysicalTraffic`): `manager.TrafficManager` runs them;
state arrays, paths, routes, legs and the compiled motion step are its parts."""
