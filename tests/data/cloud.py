"""Writes the sphere cloud of the instanced-export tests and measurements as CSV on standard
output: python3 cloud.py N > cloud.csv, beside tests/data/cloud.ron. N spheres in a cube whose
side grows with the cube root of N (100 at 100,000), placed by the R3 low-discrepancy sequence
(Roberts 2018: frac(0.5 + i / g^k), g the plastic number's generalisation, 1.2207...), so no two
runs and no two machines differ; each sphere coloured by its place in the cube (red along x,
green along y, blue along z) and of radius 0.2 to 0.5. The same formula as cloud() in
tests/it/common.rs."""
import math
import sys

n = int(sys.argv[1])
g = 1.2207440846057596
a = (1 / g, 1 / (g * g), 1 / (g * g * g))
side = 100.0 * math.cbrt(n / 100000)
print("x,y,z,radius,r,g,b")
for i in range(n):
    u = [(0.5 + a[k] * i) % 1.0 for k in range(3)]
    radius = 0.2 + 0.3 * ((0.5 + 0.6180339887498949 * i) % 1.0)
    x, y, z = ((c - 0.5) * side for c in u)
    print("%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f" % (x, y, z, radius, u[0], u[1], u[2]))
