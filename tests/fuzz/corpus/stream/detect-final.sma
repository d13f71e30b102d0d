# nverts 4
# nfaces 2
v 0 0 0
v 1 0 0
v 0 1 0
f 1 2 3
v 1 1 0
f -3 -1 -2
x 1
