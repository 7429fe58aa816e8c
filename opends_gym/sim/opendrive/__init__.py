"""OpenDRIVE roads: parsing (`parse`), reference-line geometry (`geometry`), the lane map in world
coordinates (`map`) and route planning over road links (`route`)."""
