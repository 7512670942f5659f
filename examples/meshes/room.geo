// A 4 x 3 x 2.5 room for `gmsh -2 room.geo`: every face's curve loop runs so that its normal
// points into the room (the node order of the mesh follows it); the walls are one physical
// group, the desk an obstruction.
SetFactory("Built-in");
lc = 1.0;
Point(1) = {0,0,0,lc}; Point(2) = {4,0,0,lc}; Point(3) = {4,3,0,lc}; Point(4) = {0,3,0,lc};
Point(5) = {0,0,2.5,lc}; Point(6) = {4,0,2.5,lc}; Point(7) = {4,3,2.5,lc}; Point(8) = {0,3,2.5,lc};
Line(1) = {1,2}; Line(2) = {2,3}; Line(3) = {3,4}; Line(4) = {4,1};
Line(5) = {5,6}; Line(6) = {6,7}; Line(7) = {7,8}; Line(8) = {8,5};
Line(9) = {1,5}; Line(10) = {2,6}; Line(11) = {3,7}; Line(12) = {4,8};
Curve Loop(1) = {1,2,3,4}; Plane Surface(1) = {1};
Curve Loop(2) = {5,6,7,8}; Plane Surface(2) = {-2};
Curve Loop(3) = {9,5,-10,-1}; Plane Surface(3) = {3};
Curve Loop(4) = {10,6,-11,-2}; Plane Surface(4) = {4};
Curve Loop(5) = {11,7,-12,-3}; Plane Surface(5) = {5};
Curve Loop(6) = {12,8,-9,-4}; Plane Surface(6) = {6};
// The desk top, a board in the middle of the room at 0.75 m.
Point(9) = {1.5,1,0.75,lc}; Point(10) = {2.5,1,0.75,lc}; Point(11) = {2.5,2,0.75,lc};
Point(12) = {1.5,2,0.75,lc};
Line(13) = {9,10}; Line(14) = {10,11}; Line(15) = {11,12}; Line(16) = {12,9};
Curve Loop(7) = {13,14,15,16}; Plane Surface(7) = {7};
Physical Surface("floor") = {1};
Physical Surface("ceiling") = {2};
Physical Surface("walls") = {3,4,5,6};
Physical Surface("obstruction_desk") = {7};
