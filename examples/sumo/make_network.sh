#!/bin/sh
# Regenerates road.net.xml: a straight two-lane road, 2 x 500 m, with a traffic light (B0) in the middle.
# netgenerate ships with the 'sumo' extra (pip install -e '.[sumo]').
cd "$(dirname "$0")" && netgenerate --grid --grid.x-number 3 --grid.y-number 1 --grid.length 500 \
    --default.lanenumber 2 --default.speed 30 --tls.set B0 --no-turnarounds true --seed 1 \
    --output-file road.net.xml
