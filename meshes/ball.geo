// Ball of radius 5 cm centred at (0, 0, 0.05): it rests on z = 0.
// Units: metres. gmsh -3 -setnumber lc 0.01 ball.geo
SetFactory("OpenCASCADE");
DefineConstant[ lc = {0.01, Name "lc"} ];
Sphere(1) = {0, 0, 0.05, 0.05};
Physical Volume("ball", 1) = {1};
Physical Surface("surface", 1) = Boundary{ Volume{1}; };
Mesh.CharacteristicLengthMax = lc;
Mesh.ElementOrder = 1;
Mesh.Optimize = 1;
