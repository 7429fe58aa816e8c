"""Driver models usable as agents: controllers, rule-based and distracted drivers."""
