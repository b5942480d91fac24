// Ball of radius 5 cm centred at (0, 0, 0.05), refined near its south pole (0, 0, 0) where it
// touches a floor: for the Hertz impact checks, whose contact radius a is a few mm. Elements of
// size lc_pole within dist_min of the pole, growing to lc beyond dist_max.
// Units: metres. gmsh -3 -setnumber lc 0.01 -setnumber lc_pole 0.002 ball_pole.geo
SetFactory("OpenCASCADE");
DefineConstant[ lc = {0.01, Name "lc"}, lc_pole = {0.002, Name "lc_pole"},
                dist_min = {0.012, Name "dist_min"}, dist_max = {0.04, Name "dist_max"} ];
Sphere(1) = {0, 0, 0.05, 0.05};
Physical Volume("ball", 1) = {1};
Physical Surface("surface", 1) = Boundary{ Volume{1}; };
pole() = Point In BoundingBox{-1e-6, -1e-6, -1e-6, 1e-6, 1e-6, 1e-6};
Field[1] = Distance;
Field[1].PointsList = {pole()};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = lc_pole;
Field[2].SizeMax = lc;
Field[2].DistMin = dist_min;
Field[2].DistMax = dist_max;
Background Field = 2;
Mesh.CharacteristicLengthExtendFromBoundary = 0;
Mesh.CharacteristicLengthFromPoints = 0;
Mesh.ElementOrder = 1;
Mesh.Optimize = 1;
