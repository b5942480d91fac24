// Sitting cat, about 20 cm tall, z up, base on the floor plane z = 0.
// Units: metres. Primitives (body, head, ears, tail, front paws) are fused and
// cut at z = 0, so the base is one flat surface that a scene can fix.
// Mesh size: set lc (m) from the command line: gmsh -3 -setnumber lc 0.015 cat.geo
SetFactory("OpenCASCADE");
DefineConstant[ lc = {0.015, Name "lc"} ];

Sphere(1) = {0, 0, 0.065, 1};                              // body: ellipsoid
Dilate {{0, 0, 0.065}, {0.055, 0.047, 0.075}} { Volume{1}; }
Sphere(2) = {0.028, 0, 0.142, 0.045};                      // head
Cone(3) = {0.030,  0.026, 0.160, 0.000,  0.008, 0.045, 0.018, 0.0};   // ears
Cone(4) = {0.030, -0.026, 0.160, 0.000, -0.008, 0.045, 0.018, 0.0};
Cylinder(5) = {-0.040, 0, 0.030, -0.040, 0.0, 0.070, 0.012};          // tail, rising behind
Sphere(6) = {-0.080, 0, 0.100, 0.012};                                // tail tip
Sphere(7) = {0.048,  0.024, 0.012, 0.020};                            // front paws
Sphere(8) = {0.048, -0.024, 0.012, 0.020};
BooleanUnion(10) = { Volume{1}; Delete; }{ Volume{2:8}; Delete; };
Box(20) = {-0.3, -0.3, 0, 0.6, 0.6, 0.5};                            // keep z >= 0
BooleanIntersection(30) = { Volume{10}; Delete; }{ Volume{20}; Delete; };

eps = 1e-6;
base() = Surface In BoundingBox{-1, -1, -eps, 1, 1, eps};
all() = Boundary{ Volume{30}; };
skin() = all();
skin() -= base();

Physical Volume("body", 1) = {30};
Physical Surface("base", 1) = {base()};
Physical Surface("skin", 2) = {skin()};

Mesh.CharacteristicLengthMax = lc;
Mesh.CharacteristicLengthMin = lc / 3;
Mesh.CharacteristicLengthFromCurvature = 0;
Mesh.ElementOrder = 1;
Mesh.Optimize = 1;
