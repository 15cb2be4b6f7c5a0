// Counting cells for the Cyclone-II-like estimate of orb.Report (never simulated or synthesised for real):
// a logic element in arithmetic mode per adder/comparator bit, and 18x18 (or 9x9) multiplier blocks.
(* blackbox, keep *) module ORB_CARRY(input a, input b, input bi, input ci, output s, output co); endmodule
(* blackbox, keep *) module ORB_MUL18(a, b, y);
  parameter A_WIDTH = 1; parameter B_WIDTH = 1; parameter Y_WIDTH = 1;
  input [A_WIDTH-1:0] a; input [B_WIDTH-1:0] b; output [Y_WIDTH-1:0] y;
endmodule
(* blackbox, keep *) module ORB_MUL9(a, b, y);
  parameter A_WIDTH = 1; parameter B_WIDTH = 1; parameter Y_WIDTH = 1;
  input [A_WIDTH-1:0] a; input [B_WIDTH-1:0] b; output [Y_WIDTH-1:0] y;
endmodule
