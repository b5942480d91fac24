// Slender cantilever for analytic checks: length L along x, square section a x a.
// Units: metres. Structured (transfinite) tetrahedra, n elements across the
// section and 10 n along the length: gmsh -3 -setnumber n 2 beam.geo
// Named surfaces: "clamp" (x = 0), "tip" (x = L), "sides" (the rest).
DefineConstant[ n = {2, Name "n"} ];
L = 0.25;  a = 0.01;
Point(1) = {0, 0, 0};  Point(2) = {0, a, 0};  Point(3) = {0, a, a};  Point(4) = {0, 0, a};
Line(1) = {1, 2};  Line(2) = {2, 3};  Line(3) = {3, 4};  Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = n + 1;
Transfinite Surface{1};
out[] = Extrude {L, 0, 0} { Surface{1}; Layers{10 * n}; };
// out[0] = tip face, out[1] = volume, out[2..5] = lateral faces
Physical Volume("beam", 1) = {out[1]};
Physical Surface("clamp", 1) = {1};
Physical Surface("tip", 2) = {out[0]};
Physical Surface("sides", 3) = {out[2], out[3], out[4], out[5]};
Mesh.ElementOrder = 1;
