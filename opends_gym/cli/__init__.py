"""The `opends-gym` command line."""
